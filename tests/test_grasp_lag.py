"""`gentle_grasp` on a slow skin: the fingers stop where the touch is felt, the skin's settling says
how far past the touch they closed (`skill_kit.grasp_lag`, measured on the spot), and the squeeze is
taken from there, so a 0.3-0.9 s skin is gripped about as firmly as the skin the squeeze was tuned on
(before: 17.5-22.5 N instead of ~10 N, enough to deform the gel until the cameras lose markers)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from assembly.bench.robustness import randomised_cell
from assembly.bench.run_batch import run_seeds
from behaviours.skill_kit.grasp_lag import overshoot, pressed_time

SPEED = 0.015  # m/s, gentle_grasp's default closing (0.5 mm a tick at 30 Hz)


def closed_past_touch(lag: float, fire_at: float, dt: float = 1e-4) -> tuple[float, float, float]:
    """A linear skin (reading = compression, 1 per m) of time constant `lag` pressed at SPEED from
    the touch until it shows `fire_at`: (m closed past the touch, reading shown then, settled)."""
    shown, t = 0.0, 0.0
    while shown < fire_at:
        t += dt
        pressed = SPEED * t
        shown += (pressed - shown) * (1.0 - math.exp(-dt / lag)) if lag > 0 else pressed - shown
    return SPEED * t, shown, SPEED * t


@pytest.mark.parametrize("t, lag", [(0.1, 0.033), (0.5, 0.3), (1.2, 0.9), (4.0, 1.0)])
def test_pressed_time_inverts_the_shown_over_settled_ratio(t, lag):
    ratio = t / (t - lag * (1.0 - math.exp(-t / lag)))
    assert pressed_time(ratio, lag) == pytest.approx(t, rel=1e-6)


@pytest.mark.parametrize("lag", [0.3, 0.6, 0.92])
def test_the_overshoot_is_what_a_slow_skin_closed_past_the_tuned_one(lag):
    fire_at = 0.002  # the reading of 2 mm of compression makes the detector fire
    slow, shown, settled = closed_past_touch(lag, fire_at)
    tuned, _, _ = closed_past_touch(0.033, fire_at)
    assert slow - tuned > 0.002  # the slow skin closed millimetres further before it showed the touch
    assert overshoot(shown, settled, lag, SPEED, 0.033) == pytest.approx(slow - tuned, abs=2e-4)


def test_no_overshoot_without_a_slower_skin_than_the_tuned_one():
    assert overshoot(1.0, 1.5, None, SPEED, 0.033) == 0.0  # no lag measured
    assert overshoot(1.0, 1.5, 0.03, SPEED, 0.033) == 0.0  # no slower than the profile's
    assert overshoot(1.0, 0.9, 0.5, SPEED, 0.033) == 0.0  # nothing more shown after the stop


GRASP = """version: 1
name: grasp_only
cell: {{tick_hz: 30, scene: hold}}
root:
  sequence: grasp_only
  memory: true
  children:
    - {{skill: gentle_grasp, name: grasp, params: {{squeeze: 0.001{extra}}}}}
"""


def grip_forces(tmp_path: Path, cell: str, seeds: list[int], settle_time: float | None) -> list[float]:
    """The hold scene's grip force after gentle_grasp alone, per seed (signals mode)."""
    tree = tmp_path / f"grasp_{settle_time}.yaml"
    tree.write_text(GRASP.format(extra="" if settle_time is None else f", settle_time: {settle_time}"))
    runs = run_seeds(str(tree), "signals", cell, tmp_path / tree.stem, seeds)
    return [r["metrics"]["grip force (N)"] for r in runs]


def test_a_slow_skin_is_gripped_about_as_firmly_as_the_tuned_one(tmp_path):
    (tmp_path / "cell").mkdir()
    cell = str(randomised_cell(tmp_path / "cell"))
    seeds = [1, 2]  # skins of 0.75 s and 0.92 s
    before = grip_forces(tmp_path, cell, seeds, 0.0)  # no wait: the squeeze from where the touch was felt
    after = grip_forces(tmp_path, cell, seeds, 3.0)
    assert min(before) > 15.0  # 22.5 and 17.5 N measured
    assert max(after) < 13.0 and min(after) > 5.0  # 11.5 and 9.1 N measured


def test_the_plain_cells_grip_is_unchanged(tmp_path):
    assert grip_forces(tmp_path, "sim", [0], 3.0) == grip_forces(tmp_path, "sim", [0], 0.0)
