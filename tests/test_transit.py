"""The carried element's transit path (behaviours/skill_kit/transit.py, approach_plate): over what lies on
the table, around plates and standing elements, never under a plate it does not prop; and the
assembly scene's truth catching a held element that pushes a plate anyway."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from assembly.design.model import DesignModel
from assembly.testing import TreeHarness, mock_cell
from behaviours.skill_kit.transit import Box, NoPath, element_box, plate_box, transit_path
from drivers.cell_builders import load_cell
from drivers.sim.models.plate import BeamPlate

DESIGN = DesignModel.load(Path(__file__).resolve().parents[1] / "trees" / "design" / "two_bays.json")
LENGTH, HALF_WIDTH, MARGIN = 0.435, 0.02, 0.01

# A crafted layout: the straight line from the pick area to beside plate PA passes over a lying
# element and under plate PB, whose soffit is lower than the upright element's top.
PLATES = {
    "PA": {"origin": [-0.6, 0.5, 0.46], "span": 1.0, "width": 0.2},
    "PB": {"origin": [-0.3, 0.1, 0.46], "span": 0.5, "width": 0.2},
}
LYING = element_box("EL", [0.1, -0.1, 0.025, 0.0, 0.0, 0.0], [0.435, 0.05, 0.05])
START = np.array([0.3, -0.3, 0.27])  # TCP above the pick area, element upright, foot at 0.0525 m
GOAL = np.array([-0.5, 0.34])  # 6 cm beside PA's -y edge


def obstacles() -> list[Box]:
    return [plate_box(pid, p) for pid, p in PLATES.items()] + [LYING]


def segments(start, path):
    points = [np.asarray(start, float), *path]
    return list(itertools.pairwise(points))


def test_the_straight_line_would_pass_under_a_plate_and_over_a_lying_element():
    plate = plate_box("PB", PLATES["PB"]).grown(HALF_WIDTH + MARGIN)
    assert plate.crosses(START[:2], GOAL) and LYING.crosses(START[:2], GOAL)


def test_the_path_goes_around_the_plate_and_over_the_lying_element():
    path = transit_path(START, GOAL, 0.04, LENGTH, HALF_WIDTH, obstacles(), MARGIN, max_foot=0.15)
    foot = min(p[2] for p in path[:-1]) - LENGTH / 2.0
    assert foot >= LYING.top + MARGIN - 1e-9  # the transit clears what lies on the table
    for pid, plate in PLATES.items():
        grown = plate_box(pid, plate).grown(HALF_WIDTH + MARGIN - 1e-6)
        assert not any(grown.crosses(a[:2], b[:2]) for a, b in segments(START, path)), pid
    assert path[-1] == pytest.approx([GOAL[0], GOAL[1], 0.04 + LENGTH / 2.0])
    assert all(p[2] == pytest.approx(path[0][2]) for p in path[:-1])  # level until the final descent
    straight = math.dist(START[:2], GOAL)
    travelled = sum(math.dist(a[:2], b[:2]) for a, b in segments(START, path))
    assert straight < travelled < 1.5 * straight  # a detour, not a wander


def test_a_short_element_passes_under_a_high_plate():
    high = [plate_box("PB", {**PLATES["PB"], "origin": [-0.3, 0.1, 0.9]})]
    path = transit_path(START, GOAL, 0.04, LENGTH, HALF_WIDTH, high, MARGIN, max_foot=0.15)
    assert len(path) == 2 and path[0][:2] == pytest.approx(GOAL)  # straight there under it, then down


def test_an_approach_point_just_the_margin_from_another_plate_is_clear():
    neighbour = plate_box("PN", {"origin": [-0.85, -0.10, 0.46], "span": 0.8, "width": 0.12})  # edge at y -0.16
    goal = (-0.77, -0.25 + 0.06)  # the element's side 10 mm from it, give or take rounding
    path = transit_path([0.3, -0.6, 0.27], goal, 0.04, LENGTH, HALF_WIDTH, [neighbour], MARGIN, max_foot=0.15)
    assert path[-1][:2] == pytest.approx(goal)


def test_no_path_when_the_approach_point_is_under_another_plate():
    covered = obstacles() + [Box("PC", (-0.6, 0.25), (0.4, 0.42), 0.46, math.inf)]
    with pytest.raises(NoPath, match=r"PC is in the way at the approach point \(-0.500, 0.340\)"):
        transit_path(START, GOAL, 0.04, LENGTH, HALF_WIDTH, covered, MARGIN, max_foot=0.15)


def test_no_path_when_plates_wall_the_goal_in():
    ring = [Box(f"W{i}", lo, hi, 0.46, math.inf) for i, (lo, hi) in enumerate([
        ((-0.8, 0.2), (-0.2, 0.25)), ((-0.8, 0.45), (-0.2, 0.5)), ((-0.8, 0.2), (-0.75, 0.5)), ((-0.25, 0.2), (-0.2, 0.5))])]
    with pytest.raises(NoPath, match="no way around W0, W1, W2, W3"):
        transit_path(START, GOAL, 0.04, LENGTH, HALF_WIDTH, ring, MARGIN, max_foot=0.15)


# ---- approach_plate, tick by tick ------------------------------------------------------------------
APPROACH = "version: 1\nname: t\ncell: {tick_hz: 30}\nroot: {skill: approach_plate, name: s}\n"
UPRIGHT = [0.0, -math.pi / 2, 0.0]


def approach(plates: dict, element: dict) -> TreeHarness:
    h = TreeHarness.from_text(APPROACH, cell=mock_cell(home=np.r_[START, UPRIGHT]))
    h.set("/task/plates", plates)
    h.set("/task/element", element)
    return h


def test_approach_plate_travels_around_a_plate_it_does_not_prop():
    element = {"id": "EX", "plate": "PA", "size": [LENGTH, 0.04, 0.04]}
    h = approach(PLATES, element)
    assert h.run_until_done(3000).name == "SUCCESS"
    targets = [np.asarray(c.args[0]) for c in h.arm.commands_named("move_linear")]
    assert len(targets) >= 3  # around PB's corners, then down beside PA
    grown = plate_box("PB", PLATES["PB"]).grown(HALF_WIDTH + MARGIN - 1e-6)
    assert not any(grown.crosses(a[:2], b[:2]) for a, b in segments(START, targets))
    assert h.arm.pose()[:3] == pytest.approx([-0.5, 0.34, 0.04 + LENGTH / 2.0], abs=1e-3)
    assert "-y side of PA" in h.feedback("s")


def test_approach_plate_takes_the_other_side_when_one_is_covered():
    plates = {**PLATES, "PC": {"origin": [-0.7, 0.33, 0.46], "span": 1.2, "width": 0.1}}
    h = approach(plates, {"id": "EX", "plate": "PA", "size": [LENGTH, 0.04, 0.04]})
    assert h.run_until_done(4000).name == "SUCCESS"
    assert h.arm.pose()[1] == pytest.approx(0.66, abs=1e-3) and "+y side of PA" in h.feedback("s")


def test_approach_plate_fails_naming_what_is_in_the_way_when_no_side_is_clear():
    plates = {"PA": PLATES["PA"], "PL": {"origin": [-0.7, 0.33, 0.46], "span": 1.2, "width": 0.1},
              "PU": {"origin": [-0.7, 0.67, 0.46], "span": 1.2, "width": 0.1},
              "PE": {"origin": [-0.75, 0.3, 0.46], "span": 0.12, "width": 0.4}}
    h = approach(plates, {"id": "EX", "plate": "PA", "size": [LENGTH, 0.04, 0.04]})
    assert h.run_until_done(100).name == "FAILURE"
    message = h.feedback("s")
    assert message.startswith("element EX: no clear path to plate PA (-y side: ")
    assert all(f"{pid} is in the way at the approach point" in message for pid in ("PL", "PU", "PE"))
    assert not h.arm.commands_named("move_linear")  # it never set off


def test_approach_plate_goes_around_a_standing_element_of_the_design():
    design = DesignModel.load(Path(__file__).resolve().parents[1] / "trees" / "design" / "two_bays.json")
    node = design.graph.nodes["E1"]
    node["status"], node["asbuilt_pose"] = "placed", [-0.14, -0.065, LENGTH / 2.0, *UPRIGHT]  # in E2's way
    h = TreeHarness.from_text(APPROACH, cell=mock_cell(home=np.r_[0.3, -0.3, 0.27, UPRIGHT]), design=design)
    h.set("/task/plates", design.plates())
    h.set("/task/element", design.element("E2"))
    assert h.run_until_done(4000).name == "SUCCESS"
    targets = [np.asarray(c.args[0]) for c in h.arm.commands_named("move_linear")]
    e1 = element_box("E1", node["asbuilt_pose"], [LENGTH, 0.04, 0.04]).grown(HALF_WIDTH + MARGIN - 1e-6)
    assert not any(e1.crosses(a[:2], b[:2]) for a, b in segments([0.3, -0.3, 0.27], targets))
    plates = [plate_box(pid, p) for pid, p in design.plates().items()]
    unaware = transit_path([0.3, -0.3, 0.27], targets[-1][:2], 0.04, LENGTH, HALF_WIDTH, plates, MARGIN, 0.15)
    assert any(e1.crosses(a[:2], b[:2]) for a, b in segments([0.3, -0.3, 0.27], unaware))  # E1 was in the way


# ---- the scene's truth: a held element pushing a plate -------------------------------------------
CARRY_UNDER_P1 = """version: 1
name: carry
root:
  sequence: s
  memory: true
  children:
    - {{skill: gentle_grasp, name: grasp}}
    - {{skill: move_to, name: lift, params: {{offset: [0.0, 0.0, 0.25]}}}}
    - {{skill: rotate_element, name: upright, params: {{angle: 90}}}}
    - {{skill: move_to, name: carry, params: {{offset: [{dx}, {dy}, 0.0], speed: 0.15}}}}
"""


def carry_under_p1(element: str, light_p1: bool = False):
    """Grasp `element` at its middle, stand it upright with its top 15 mm above the plates'
    soffits and carry it straight to under P1's middle; the scene, and the run's status."""
    cell = load_cell("sim", 30, "assembly", DESIGN.scene_args(), seed=0)
    world = cell.world
    if light_p1:
        world.plates["P1"].beam = BeamPlate(span=1.0, w=10.0, P=0.0)
    start = world.elements[element].pose[:3]
    world.arm._pose[:3] = start
    h = TreeHarness.from_text(CARRY_UNDER_P1.format(dx=-start[0], dy=0.3 - start[1]), cell=cell)
    return world, h.run_until_done(3000)


def test_a_held_element_dragged_under_a_plate_it_does_not_prop_is_a_shortfall():
    world, status = carry_under_p1("E2")  # E2 props P2; its top ends 15 mm above P1's soffit
    assert status.name == "SUCCESS"  # the tree carried on: only the truth knows
    pushes = world.shortfalls({"max_regret": 0.01})
    assert len(pushes) == 1 and pushes[0].startswith("E2 pushed P1, which it does not prop, with up to ")
    assert float(pushes[0].split("up to ")[1].split(" N")[0]) > 30.0
    assert world.metrics()["plates pushed"] == pushes[0]


def test_a_held_element_pushing_its_own_plate_is_no_shortfall():
    world, status = carry_under_p1("E1")  # E1 props P1 (as when it scans under it)
    assert status.name == "SUCCESS" and world.shortfalls({"max_regret": 0.01}) == []
    assert world.plate_load(world.elements["E1"]) > 30.0


def test_an_element_lifting_a_plate_off_its_supports_is_a_shortfall():
    world, status = carry_under_p1("E1", light_p1=True)  # P1 weighs 10 N; E1 pushes it harder
    assert status.name == "SUCCESS"
    assert any(s.startswith("E1 lifted P1 off its supports with up to ") for s in world.shortfalls({"max_regret": 0.01}))
