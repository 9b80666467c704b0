"""press_with_force: presses until the target force is reached and holds, on a fast skin and on a
lagging skin whose gain is not the model's (it stands to measure the lag, scales the learned force to
the arm's TCP force and corrects by the measured stiffness); reports pressing into nothing and
unusable models, stops when halted; on the press scene the scale feels the target. The helpers it
measures with are tested on exact first-order responses."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from assembly.errors import TreeErrors
from assembly.testing import TreeHarness, touch
from behaviours.press_with_force import Stand, correction, steady, time_constant
from drivers.cell_builders import load_cell
from perception.learning.models import load_model

GRIP, WEIGHT = 10.0, 0.05 * 9.81


def one_skill(params: str = "{}") -> TreeHarness:
    return TreeHarness.from_text(f"version: 1\nname: t\nroot: {{skill: press_with_force, name: s, params: {params}}}\n")


def stick_on_scale(h, stiffness: float = 4000.0, lag: float = 0.0, gain: float = 1.0,
                   felt: list[float] | None = None, gap: float = 0.002, arm_feels: bool = True) -> Callable:
    """A stick whose tip meets a surface `gap` below the start and is pushed back by it; the arm's TCP
    feels that push at once, the skin shows it through a first-order `lag` (s) and `gain` times too
    much; `felt` collects the true force each tick."""
    z0 = h.arm.pose()[2] - gap
    shown = [0.0, 0.0]  # the skin's load, the time it was last updated

    def script(tick, t):
        force = stiffness * max(0.0, z0 - h.arm.pose()[2]) if stiffness else 0.0
        h.cell.world.arm.external_wrench = np.array([0.0, 0.0, force if arm_feels else 0.0, 0.0, 0.0, 0.0])
        if felt is not None:
            felt.append(force)
        follow = 1.0 - math.exp(-(t - shown[1]) / lag) if lag > 0.0 else 1.0
        shown[0], shown[1] = shown[0] + (force - shown[0]) * follow, t
        load_z = WEIGHT - gain * shown[0]  # on the hand, along tool z (down at the home pose)
        return {f: touch(f, normal=GRIP, shear=(0.0, load_z / 2), area=0.2) for f in ("left", "right")}
    return script


def test_press_with_force_reaches_the_target_and_holds():
    h = one_skill("{target: 4.0}")
    felt: list[float] = []
    h.script(stick_on_scale(h, felt=felt))
    assert h.run_until_done(1500).name == "SUCCESS"
    assert h.blackboard("/task/press_force") == pytest.approx(4.0, abs=0.3)
    assert felt[-1] == pytest.approx(4.0, abs=0.3) and not h.arm.is_moving()
    twists = np.array([c.args[0] for c in h.arm.commands_named("speed_linear")])
    assert twists[0][2] == pytest.approx(-0.005)  # full speed down (tool z) while far from the target
    assert abs(twists[-1][2]) < 0.001  # slowed before it stood


@pytest.mark.parametrize("lag, gain", [(1.0, 1.3), (1.0, 0.7), (0.5, 1.0)])
def test_press_with_force_on_a_lagging_skin_of_another_gain_ends_at_the_target(lag, gain):
    """Before (the profile's lag trusted, the learned force taken as it reads): 1 s of lag and a skin
    30 % more sensitive than the model's ended far from the target. Now the skill stands, measures
    the lag (within a few ticks of the skin's), and judges the force on the arm's TCP force."""
    h = one_skill("{target: 5.0}")
    felt: list[float] = []
    h.script(stick_on_scale(h, lag=lag, gain=gain, felt=felt, gap=-0.0005))  # where a contact search stopped: 2 N
    assert h.run_until_done(3000).name == "SUCCESS", h.feedback("s")
    assert felt[-1] == pytest.approx(5.0, abs=0.3)
    assert max(felt) < 5.0 + 2.0  # the press never runs far past the target on a late skin
    assert _lag_reported(h) == pytest.approx(lag, abs=0.15)


def test_press_with_force_starting_past_the_target_eases_off_even_when_the_learned_force_reads_low():
    """The contact search stopped at 8 N; the skin reads half the load. Before, the learned force
    (4 N of 5) pressed on to 20 N before the arm's force stopped it (randomised seed 1)."""
    h = one_skill("{target: 5.0}")
    felt: list[float] = []
    h.script(stick_on_scale(h, lag=0.75, gain=0.5, felt=felt, gap=-0.002))
    assert h.run_until_done(3000).name == "SUCCESS", h.feedback("s")
    assert felt[-1] == pytest.approx(5.0, abs=0.3) and max(felt) < 8.0 + 1.0


def test_press_with_force_fails_when_the_arm_does_not_feel_the_press():
    h = one_skill("{target: 4.0}")
    felt: list[float] = []
    h.script(stick_on_scale(h, felt=felt, arm_feels=False))
    assert h.run_until_done(1500).name == "FAILURE"
    assert "does not read the press" in h.feedback("s") and max(felt) < 4.0 + 1.0


def _lag_reported(h) -> float:
    return float(h.feedback("s").split("skin lag ")[1].split(" s")[0])


def test_press_with_force_reports_nothing_under_the_object():
    h = one_skill("{max_travel: 0.02}")
    h.script(stick_on_scale(h, stiffness=0.0))
    assert h.run_until_done(1500).name == "FAILURE"
    assert "nothing under the object" in h.feedback("s") and not h.arm.is_moving()


def test_press_with_force_refuses_a_model_of_another_kind_before_it_runs(tmp_path):
    stir = load_model("trees/models/stir_sim.npz", "stir")
    path = stir.save(tmp_path / "stir.npz")
    with pytest.raises(TreeErrors) as err:
        one_skill(f"{{model: {path}}}")
    assert "a 'force' model is needed" in str(err.value)


def test_press_with_force_halted_stops_the_arm():
    h = one_skill()
    h.script(stick_on_scale(h))
    for _ in range(300):  # it stands first, measuring the skin, then presses
        h.tick()
        if h.arm.is_moving():
            break
    assert h.arm.is_moving()
    h.halt()
    assert not h.arm.is_moving()


@pytest.mark.parametrize("target", [2.0, 8.0])
def test_the_scale_feels_the_target(target):
    cell = load_cell("sim", 30, "press", {})
    text = Path("trees/press_with_force.yaml").read_text().replace("target: 5.0", f"target: {target}")
    harness = TreeHarness.from_text(text, cell=cell, name="trees/press_with_force.yaml")
    assert harness.run_until_done(2000).name == "SUCCESS"
    assert cell.world.force == pytest.approx(target, abs=0.3)


def first_order(start: float, final: float, tau: float, period: float, n: int) -> list[float]:
    return [final + (start - final) * math.exp(-i * period / tau) for i in range(n)]


@pytest.mark.parametrize("tau", [0.1, 0.5, 1.0])
def test_time_constant_of_a_first_order_settling(tau):
    values = first_order(2.0, 7.0, tau, 1 / 30, 200)
    assert time_constant(values, 7.0, 0.01, 1 / 30) == pytest.approx(tau, abs=1 / 30)
    assert time_constant([5.0] * 50, 5.0, 0.01, 1 / 30) is None  # no change: no lag to see


def test_steady_waits_for_a_slow_skin_and_tolerates_noise():
    slow = first_order(0.0, 5.0, 1.0, 1 / 30, 90)  # 3 s of a 1 s skin: still 0.25 N to go
    assert not steady(slow[:60], 30, 0.05)
    assert steady(first_order(0.0, 5.0, 1.0, 1 / 30, 300), 30, 0.05)
    noisy = list(5.0 + np.random.default_rng(0).normal(0.0, 0.3, 60))
    assert steady(noisy, 30, 0.05)  # within the noise of the means


def test_correction_steps_by_the_measured_stiffness():
    assert correction([(0.0, 3.0), (0.001, 7.0)], 5.0) == pytest.approx(-0.0005)  # 4000 N/m: back half a mm
    assert correction([(0.0, 3.0), (0.0005, 5.2), (0.001, 6.8)], 5.0) == pytest.approx(-1.8 / 3800)  # fitted: 3800 N/m
    assert correction([(0.0, 3.0)], 5.0) is None  # one stand shows no stiffness
    assert correction([(0.0, 4.5), (0.0001, 4.4)], 5.0) is None  # 0.1 mm apart: noise, not stiffness
    assert correction([(0.0, 0.1), (0.001, 0.1)], 5.0) is None  # nothing felt at either
    assert correction([(0.0, 1.0), (0.001, 1.01)], 50.0) == pytest.approx(0.003)  # at most MAX_STEP


def test_stand_scales_the_learned_force_to_the_arm():
    assert Stand(4.0, 5.0, 0.1, None).calibration(1.0) == pytest.approx(1.25)
    assert Stand(0.2, 5.0, 0.1, None).calibration(1.0) == 1.0  # too little learned force to tell
