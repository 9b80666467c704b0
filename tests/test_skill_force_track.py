"""force_track: SpeedCtrl on the marker force, tick by tick on the mocked cell, and FollowMe on
the simulated scene in every tool axis."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from assembly.testing import TreeHarness, mock_cell, touch
from behaviours.skill_kit.control import speed_ctrl
from drivers.cell_builders import load_cell
from perception.sensor_profile import default_profile

GRIP = 10.0  # N squeeze on each pad


def one_skill(params: str = "{}") -> TreeHarness:
    return TreeHarness.from_text(f"version: 1\nname: t\nroot: {{skill: force_track, name: s, params: {params}}}\n")


def pulled(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> dict:
    """Both pads holding a block that a person pulls with (x, y, z) N in tool axes."""
    return {"left": touch("left", normal=GRIP - y / 2, shear=(-x / 2, z / 2), area=0.3),
            "right": touch("right", normal=GRIP + y / 2, shear=(x / 2, z / 2), area=0.3)}


def test_speed_ctrl_maps_the_force_range_onto_the_speed_range():
    v = speed_ctrl(np.array([0.05, -1.0, 3.0]), 0.01, 0.1, 0.2, 2.0, eps=0.1)
    assert v == pytest.approx([0.0, -(0.01 + 0.05 * 0.8), 0.1])  # dead band, linear, saturated


def test_force_track_moves_along_the_pull_and_stops_after_the_duration():
    h = one_skill("{duration: 1.0, smoothing: 1}")
    h.script(lambda tick, t: pulled(x=6.0 if tick >= 10 else 0.0))  # reference first, then a pull
    assert h.run_until_done(100).name == "SUCCESS"
    twists = np.array([c.args[0] for c in h.arm.commands_named("speed_linear")])
    assert np.all(twists[:, 1:] == 0.0)  # tool x is base x at the home pose; nothing else moves
    gain = default_profile().shear_px_per_n  # px per N of the sensor the cell has
    assert twists[:, 0].max() == pytest.approx(0.1 * (6 * gain - 0.05) / 1.95, rel=0.05)  # SpeedCtrl
    assert h.arm.commands[-1].name == "stop"


def top_speed(axis: str, newtons: float, cell=None) -> float:
    h = TreeHarness.from_text("version: 1\nname: t\nroot: {skill: force_track, name: s, params: "
                              "{duration: 1.0, smoothing: 1}}\n", cell=cell)
    h.script(lambda tick, t: pulled(**{axis: newtons if tick >= 10 else 0.0}))
    assert h.run_until_done(100).name == "SUCCESS"
    return float(np.abs(np.array([c.args[0][:3] for c in h.arm.commands_named("speed_linear")])).max())


def test_a_newton_moves_the_hand_as_fast_on_the_closing_axis_as_along_the_pads():
    """normal_scale comes from the sensor profile (its shear/normal gain ratio), not a simulator constant."""
    assert top_speed("y", 5.0) == pytest.approx(top_speed("x", 5.0), rel=0.1)
    cell = mock_cell()
    cell.sensor_profile = dataclasses.replace(default_profile(), normal_px_per_n=0.085)  # a cell whose sensor differs
    # the fingertips still move 0.17 px/N (the scripted touch): weighted 2x, the push reads twice as large
    assert top_speed("y", 2.0, cell) == pytest.approx(top_speed("y", 4.0), rel=0.1)


def test_force_track_follows_a_push_on_the_closing_axis():
    h = one_skill("{duration: 1.0, smoothing: 1}")
    h.script(lambda tick, t: pulled(y=5.0 if tick >= 10 else 0.0))
    assert h.run_until_done(100).name == "SUCCESS"
    twists = np.array([c.args[0] for c in h.arm.commands_named("speed_linear")])
    assert twists[-1][1] < -0.01  # tool y points along base -y at the home pose


def test_force_track_fails_when_the_object_leaves_the_fingers():
    h = one_skill("{duration: 5.0}")
    h.script([(0, pulled()), (30, {f: touch(f) for f in ("left", "right")})])
    assert h.run_until_done(200).name == "FAILURE"
    assert "lost the object" in h.feedback("s") and not h.arm.is_moving()


def test_force_track_rejects_unknown_axes():
    with pytest.raises(Exception, match="axes must be"):
        one_skill("{axes: xw}")


def test_force_track_halted_stops_the_arm():
    h = one_skill("{duration: 0}")
    h.script(lambda tick, t: pulled(z=5.0 if tick >= 10 else 0.0))
    h.tick(20)
    assert h.arm.is_moving()
    h.halt()
    assert h.status("s") == "INVALID" and not h.arm.is_moving()


@pytest.mark.parametrize("axis,direction", [("x", "pull"), ("y", "push"), ("z", "pull")])
def test_force_track_follows_a_person_in_the_followme_scene(axis, direction):
    cell = load_cell("sim", 30, "followme", {"axis": axis, "direction": direction})
    h = TreeHarness.from_file("trees/force_track.yaml", cell=cell)
    assert h.run_until_done(1000).name == "SUCCESS"
    m = cell.world.metrics()
    assert m["tracking error final (mm)"] < 5.0 and m["tracking error rms (mm)"] < 20.0
    assert not m["block lost"]
