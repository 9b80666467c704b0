"""release: opens with the leaky integrator, then judges the release by feel and sight (stuck,
fell, still there); halting; and letting go of a stick pressed on the scale."""

from __future__ import annotations

import numpy as np
import pytest

from assembly.testing import TreeHarness, mock_cell, touch
from drivers.cell_builders import load_cell

EMPTY = {f: touch(f) for f in ("left", "right")}


def one_skill(params: str = "{}") -> TreeHarness:
    text = f"version: 1\nname: t\nroot: {{skill: release, name: s, params: {params}}}\n"
    return TreeHarness.from_text(text, cell=mock_cell(gripper_width=0.035, object_width=0.04))


def seen(normal: float = 0.0) -> dict:
    return {f: touch(f, normal=normal, area=0.3) for f in ("left", "right")}


def squeezed_until_open(h, after: dict) -> callable:
    """Squeezed while the fingers are closer than the 40 mm object, then `after`."""
    return lambda tick, t: seen(normal=10.0) if h.gripper.width() < 0.04 else after


def test_release_opens_with_the_leaky_integrator_and_leaves_the_object_standing():
    h = one_skill("{alpha: 0.8, opening: 0.02}")
    h.script(squeezed_until_open(h, seen()))
    assert h.run_until_done(200).name == "SUCCESS"
    widths = np.array([c.args[0] for c in h.gripper.commands_named("move")])
    x = (widths - 0.035) / 0.02
    assert np.allclose(x, [1 - 0.8 ** (k + 1) for k in range(len(x))])  # x_t = a x_{t-1} - (1 - a) L, L = -1
    assert "object stays" in h.feedback("s")


def test_release_reports_an_object_that_fell():
    h = one_skill()
    h.script(squeezed_until_open(h, EMPTY))
    assert h.run_until_done(200).name == "FAILURE"
    assert "the object fell when released" in h.feedback("s")


def test_release_reports_an_object_stuck_between_the_fingers():
    h = one_skill()
    h.script(lambda tick, t: seen(normal=10.0))  # still squeezed after opening
    assert h.run_until_done(200).name == "FAILURE"
    assert "still feel a squeeze" in h.feedback("s") and "stuck" in h.feedback("s")


def test_release_expecting_the_object_to_leave():
    h = one_skill("{expect: leaves}")
    h.script(squeezed_until_open(h, seen()))
    assert h.run_until_done(200).name == "FAILURE"
    assert "still between the fingers" in h.feedback("s")
    h = one_skill("{expect: leaves}")
    h.script(squeezed_until_open(h, EMPTY))
    assert h.run_until_done(200).name == "SUCCESS"
    h = one_skill("{expect: leaves}")  # a few background pixels of the object's colours stay in view
    h.script(squeezed_until_open(h, {"left": touch("left", area=0.01), "right": touch("right")}))
    assert h.run_until_done(200).name == "SUCCESS"


def test_release_refuses_an_empty_hand():
    h = one_skill()
    assert h.run_until_done(5).name == "FAILURE" and "nothing between the fingers" in h.feedback("s")


def test_release_halted_stops_the_gripper():
    h = one_skill("{alpha: 0.99}")
    h.script(squeezed_until_open(h, seen()))
    h.tick(5)
    h.halt()
    assert h.status("s") == "INVALID" and h.gripper.commands[-1].name == "stop"


PRESS_AND_LET_GO = """version: 1
name: press_release
cell: {tick_hz: 30, scene: press}
root:
  sequence: s
  memory: true
  children:
    - {skill: gentle_grasp, name: grasp, params: {squeeze: 0.002}}
    - {skill: descend_until_contact, name: touch, params: {speed: 0.005, eps: 0.3}}
    - {skill: move_to, name: press, params: {offset: [0.0, 0.0, -0.001], speed: 0.001}}
    - {skill: release, name: let_go}
"""


def test_a_stick_pressed_on_the_scale_is_let_go_and_stays():
    cell = load_cell("sim", 30, "press", {})
    h = TreeHarness.from_text(PRESS_AND_LET_GO, cell=cell)
    assert h.run_until_done(2000).name == "SUCCESS"
    metrics = cell.world.metrics()
    assert metrics["stick"] == "released, resting on the scale"
    assert metrics["force on the scale (N)"] == pytest.approx(0.05 * 9.81, abs=1e-3)  # only its weight
