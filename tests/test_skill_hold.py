"""hold: tightens a step on slip, reports losing the object, stops the gripper when halted;
in the hold scene it keeps a box that is being filled, which slips out without it."""

from __future__ import annotations

from pathlib import Path

import pytest

from assembly.testing import TreeHarness, mock_cell, touch
from drivers.cell_builders import load_cell

TREES = Path(__file__).resolve().parents[1] / "trees"


def one_skill(params: str = "{}", **cell_kw) -> TreeHarness:
    text = f"version: 1\nname: t\nroot: {{skill: hold, name: s, params: {params}}}\n"
    return TreeHarness.from_text(text, cell=mock_cell(**cell_kw) if cell_kw else None)


def held(slip: float = 0.0) -> dict:
    return {f: touch(f, normal=10.0, area=0.3, slip=slip / 2) for f in ("left", "right")}


def test_hold_closes_one_step_per_slip_burst_then_succeeds():
    h = one_skill("{duration: 2.0, slip: 0.06, step: 0.0005}", gripper_width=0.04)
    h.script(lambda tick, t: held(0.1 if tick in (10, 11, 30) else 0.0))
    assert h.run_until_done(200).name == "SUCCESS"
    widths = [c.args[0] for c in h.gripper.commands_named("move")]
    assert widths == pytest.approx([0.0395, 0.039, 0.0385])  # one step per slipping tick
    assert h.ticks == pytest.approx(61, abs=1)  # 2 s at 30 Hz


def test_hold_fails_when_the_object_leaves_the_grip():
    h = one_skill("{duration: 5.0}")
    h.script([(0, held()), (20, {f: touch(f) for f in ("left", "right")})])
    assert h.run_until_done(300).name == "FAILURE"
    assert "left the grip after 0 tightening steps" in h.feedback("s")
    h = one_skill("{duration: 5.0}")  # a few background pixels of the object's colours stay in view
    h.script([(0, held()), (20, {"left": touch("left", area=0.01), "right": touch("right")})])
    assert h.run_until_done(300).name == "FAILURE"
    assert "left the grip" in h.feedback("s")


def test_hold_refuses_to_start_without_an_object():
    h = one_skill()
    assert h.run_until_done(5).name == "FAILURE"
    assert "grasp the object first" in h.feedback("s")


def test_hold_halted_stops_the_gripper():
    h = one_skill("{duration: 0}", gripper_width=0.04)
    h.script(lambda tick, t: held(0.2))
    h.tick(5)
    assert h.status("s") == "RUNNING"
    h.halt()
    assert h.status("s") == "INVALID" and h.gripper.commands[-1].name == "stop"


def run_scene(slip_threshold: float) -> tuple[str, dict]:
    text = (TREES / "hold.yaml").read_text().replace("{duration: 8.0}", f"{{duration: 8.0, slip: {slip_threshold}}}")
    cell = load_cell("sim", 30, "hold", {})
    h = TreeHarness.from_text(text, cell=cell)
    return h.run_until_done(1000).name, cell.world.metrics()


def test_hold_keeps_a_box_being_filled_which_slips_out_without_it():
    status, metrics = run_scene(0.06)
    assert status == "SUCCESS" and not metrics["box dropped"]
    assert metrics["box slid (mm)"] < 5.0
    assert metrics["grip force (N)"] * 2 * 0.8 > metrics["load on the grip (N)"]  # tightened enough
    status, metrics = run_scene(100.0)  # never reacts
    assert status == "FAILURE" and metrics["box dropped"]


def test_hold_fails_when_the_object_keeps_slipping_at_the_force_limit():
    """The fingers stop closing once the squeeze reaches the force limit (40 N on a 40 mm object
    with 5000 N/m gels: at 32 mm); slip on every tick after that fails the hold."""
    h = one_skill("{duration: 0, limit_steps: 10}", gripper_width=0.034, object_width=0.04)
    h.script(lambda tick, t: held(0.1))
    ticks_at_limit = None
    while h.tick().name == "RUNNING":
        if ticks_at_limit is None and h.gripper.object_detected():
            ticks_at_limit = h.ticks
        assert h.ticks < 100
    assert h.status("s") == "FAILURE"
    assert "keeps slipping with the gripper at its force limit (40 N, 32.0 mm)" in h.feedback("s")
    assert h.ticks - ticks_at_limit == pytest.approx(10, abs=2)  # limit_steps triggers that did not close
    assert h.gripper.commands[-1].name == "stop"


def test_hold_fails_in_the_scene_when_the_load_beats_the_gripper():
    text = (TREES / "hold.yaml").read_text().replace("{duration: 8.0}", "{duration: 8.0, force: 15.0}")
    cell = load_cell("sim", 30, "hold", {"extra_load": 30.0})
    h = TreeHarness.from_text(text, cell=cell)
    assert h.run_until_done(1000).name == "FAILURE"
    assert "force limit (15 N" in h.feedback("hold_demo/hold")
