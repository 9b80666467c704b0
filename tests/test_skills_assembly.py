"""Each assembly skill ticked on the mocked cell with scripted perception: success, the failure
it should report, and being halted mid-run. A few use the simulated assembly scene instead."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from assembly.design import DesignModel
from assembly.testing import TreeHarness, mock_cell, touch
from behaviours.geometry import angle_between
from drivers.cell_builders import load_cell

DESIGN = DesignModel.load(Path(__file__).resolve().parents[1] / "trees" / "design" / "two_bays.json")
E1 = DESIGN.element("E1")


def one_skill(skill: str, params: str = "{}", cell=None, tick_hz: int = 30) -> TreeHarness:
    text = f"version: 1\nname: t\ncell: {{tick_hz: {tick_hz}}}\nroot: {{skill: {skill}, name: s, params: {params}}}\n"
    return TreeHarness.from_text(text, cell=cell)


def both(**kw) -> dict:
    return {f: touch(f, **kw) for f in ("left", "right")}


def axial(load: float, **kw) -> dict:
    """Both fingers feeling `load` N pushed down the axis of an upright element (tool x)."""
    return {"left": touch("left", shear=(load / 2, 0.0), **kw), "right": touch("right", shear=(-load / 2, 0.0), **kw)}


def sim_cell(seed: int = 0):
    return load_cell("sim", 30, "assembly", DESIGN.scene_args(), seed=seed)


# ---- gentle_grasp ---------------------------------------------------------------------------
def squeeze_script(h, object_width=0.04, stiffness=5000.0):
    return lambda tick, t: both(normal=max(0.0, (object_width - h.gripper.width()) * stiffness))


def test_gentle_grasp_stops_at_first_contact_then_squeezes():
    h = one_skill("gentle_grasp", "{squeeze: 0.004}")
    h.script(squeeze_script(h))
    assert h.run_until_done(400).name == "SUCCESS"
    contact = h.blackboard("/task/grasp_width")
    assert 0.037 < contact < 0.0401  # felt within a few 0.5 mm steps of the object
    widths = [c.args[0] for c in h.gripper.commands_named("move")]
    steps = np.diff(widths[:-1])
    assert np.allclose(steps, -0.0005)  # small equal closing steps
    assert widths[-1] == pytest.approx(contact - 0.004)  # then the holding squeeze


def test_gentle_grasp_fails_when_nothing_is_felt():
    h = one_skill("gentle_grasp", "{step: 0.002}")
    assert h.run_until_done(200).name == "FAILURE"
    assert "without feeling an object" in h.feedback("s")
    assert h.gripper.width() <= 0.002


def test_gentle_grasp_gives_up_when_the_fingers_stop_without_feeling_anything():
    h = one_skill("gentle_grasp", "{max_time: 2.0}", cell=mock_cell(object_width=0.04))
    assert h.run_until_done(200).name == "FAILURE"  # blocked on the object, FingerVision blind
    assert "no contact felt within 2 s" in h.feedback("s") and not h.gripper.is_moving()


def test_gentle_grasp_halted_stops_the_gripper():
    h = one_skill("gentle_grasp")
    h.tick(5)
    h.halt()
    assert h.status("s") == "INVALID" and h.gripper.commands[-1].name == "stop"


# ---- descend_until_contact ------------------------------------------------------------------
def test_descend_stops_when_the_force_changes():
    h = one_skill("descend_until_contact", "{speed: 0.02, eps: 0.5}")
    h.script(lambda tick, t: axial(-30.0 * max(0.0, 0.45 - h.arm.pose()[2]) / 0.001))
    assert h.run_until_done(300).name == "SUCCESS"
    assert h.blackboard("/task/contact_pose")[2] == pytest.approx(0.45, abs=0.002)
    assert h.arm.commands_named("speed_linear")[0].args[0][2] == pytest.approx(-0.02)
    assert h.arm.commands[-1].name == "stop"


def test_descend_fails_without_contact():
    h = one_skill("descend_until_contact", "{speed: 0.05, max_travel: 0.05}")
    assert h.run_until_done(300).name == "FAILURE"
    assert "no contact within 0.05 m" in h.feedback("s")
    assert not h.arm.is_moving()


def test_descend_halted_stops_the_arm():
    h = one_skill("descend_until_contact")
    h.tick(10)
    assert h.arm.is_moving()
    h.halt()
    assert not h.arm.is_moving()


# ---- locate_element and vis_scan (simulated scene) -------------------------------------------
def test_locate_and_scan_measure_the_element_in_the_scene():
    cell = sim_cell()
    h = TreeHarness.from_text(
        "version: 1\nname: t\nroot:\n  sequence: s\n  memory: true\n  children:\n"
        "    - {skill: locate_element}\n    - {skill: vis_scan}\n", cell=cell)
    h.set("/task/element", E1)
    assert h.run_until_done(2000).name == "SUCCESS"
    true = cell.world.elements["E1"]
    assert h.blackboard("/task/element_length") == pytest.approx(true.length, abs=0.001)
    centre = h.blackboard("/task/element_pose")[:2]
    assert np.linalg.norm(centre - true.pose[:2]) < 0.002  # the middle of the real element


def test_locate_fails_when_nothing_is_between_the_fingers():
    h = one_skill("locate_element")
    h.set("/task/element", E1)
    assert h.run_until_done(1000).name == "FAILURE"
    assert "not seen between the fingers" in h.feedback("s")


def test_vis_scan_fails_when_no_end_is_found():
    h = one_skill("vis_scan", "{max_travel: 0.05}")
    h.script(lambda tick, t: both(area=0.3))  # the object never leaves the view
    assert h.run_until_done(500).name == "FAILURE"
    assert "no element end within 0.05 m" in h.feedback("s")


def test_vis_scan_rejects_a_length_far_from_the_design():
    h = one_skill("vis_scan", "{step: 0.005}")
    h.set("/task/element", {**E1, "size": [0.30, 0.04, 0.04]})
    start_x = h.arm.pose()[0]
    h.script(lambda tick, t: both(area=0.3 if abs(h.arm.pose()[0] - start_x) < 0.2 else 0.0))
    assert h.run_until_done(500).name == "FAILURE"
    assert "differs from the design" in h.feedback("s")


# ---- rotate_element ---------------------------------------------------------------------------
def test_rotate_turns_about_the_finger_axis():
    h = one_skill("rotate_element", "{angle: 90}")
    start = h.arm.pose()
    assert h.run_until_done(300).name == "SUCCESS"
    assert angle_between(start, h.arm.pose()) == pytest.approx(np.pi / 2, abs=1e-6)


def test_rotate_aborts_on_slip():
    h = one_skill("rotate_element")
    h.script(lambda tick, t: both(slip=0.2 if tick > 3 else 0.0))
    assert h.run_until_done(300).name == "FAILURE"
    assert "slipping" in h.feedback("s") and h.arm.commands[-1].name == "stop"


def test_rotate_refuses_to_swing_into_the_ground():
    h = one_skill("rotate_element")
    h.set("/task/element_length", 1.2)
    assert h.run_until_done(10).name == "FAILURE"
    assert "lift first" in h.feedback("s")


# ---- find_max_load ------------------------------------------------------------------------------
PLATES = DESIGN.plates()


def scripted_plate(h, peak: float, rng):
    """Load felt in the grip as the element slides under P1: a parabola peaking at `peak` (m
    along the span) with 2 % noise, zero outside the loaded zone."""
    x0 = PLATES["P1"]["origin"][0]

    def script(tick, t):
        pose = h.arm.pose()
        under = abs(pose[1] - PLATES["P1"]["origin"][1]) < 0.1
        a = pose[0] - x0
        load = max(0.0, 20.0 * (1 - ((a - peak) / 0.35) ** 2)) if under else 0.0
        return axial(load + rng.normal(0, 0.4))
    return script


def test_find_max_load_locates_the_peak():
    h = one_skill("find_max_load", "{speed: 0.05}")
    h.set("/task/element", E1)
    h.set("/task/plates", PLATES)
    h.script(scripted_plate(h, 0.57, np.random.default_rng(0)))
    assert h.run_until_done(3000).name == "SUCCESS"
    best = h.blackboard("/task/best_pose")
    assert best[0] - PLATES["P1"]["origin"][0] == pytest.approx(0.57, abs=0.02)
    assert h.arm.pose()[0] == pytest.approx(best[0], abs=1e-6)
    profile = h.blackboard("/task/load_profile")
    assert len(profile["position"]) > 100
    assert profile["best_load"] == pytest.approx(profile["smoothed"].max(), rel=0.05)


def test_find_max_load_fails_when_the_plate_is_never_touched():
    h = one_skill("find_max_load", "{speed: 0.1}")
    h.set("/task/element", E1)
    h.set("/task/plates", PLATES)
    assert h.run_until_done(3000).name == "FAILURE"
    assert "no load found along the plate" in h.feedback("s")


def test_find_max_load_halted_mid_scan_stops_the_arm():
    h = one_skill("find_max_load")
    h.set("/task/element", E1)
    h.set("/task/plates", PLATES)
    h.tick(200)
    assert h.status("s") == "RUNNING" and h.arm.is_moving()
    h.halt()
    assert not h.arm.is_moving() and h.arm.commands[-1].name == "stop"


# ---- place_element -------------------------------------------------------------------------------
def test_place_opens_with_the_leaky_integrator_and_records_the_pose():
    h = one_skill("place_element", "{alpha: 0.8, opening: 0.02}")
    h.set("/task/element", E1)
    h.set("/task/measured_load", 4.2)
    h.script(lambda tick, t: both(area=0.3))
    start = h.gripper.width()
    assert h.run_until_done(500).name == "SUCCESS"
    widths = np.array([c.args[0] for c in h.gripper.commands_named("move")])
    x = (widths - start) / 0.02
    expected = [1 - 0.8 ** (k + 1) for k in range(len(x))]  # x_t = a x_{t-1} - (1 - a) L, L = -1
    assert np.allclose(x, expected)
    asbuilt = h.blackboard("/task/asbuilt")
    assert asbuilt["element"] == "E1" and asbuilt["load"] == 4.2
    assert h.arm.pose()[1] == pytest.approx(asbuilt["pose"][1] - 0.2)  # backed out


def test_place_reports_a_fallen_element():
    h = one_skill("place_element")
    h.set("/task/element", E1)
    assert h.run_until_done(500).name == "FAILURE"
    assert "it fell" in h.feedback("s")
