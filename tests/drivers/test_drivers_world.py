"""The simulated worlds: every scene is a World around arms and grippers typed by protocol, the
assembly scene's loads come from the scene file next to the design, and its truth feeds reports."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from assembly.design.model import DesignModel
from drivers.cell_builders import load_cell
from drivers.clock import SimClock
from drivers.emulators.shadow import FollowedArm, FollowedGripper
from drivers.protocols import SceneArm, SceneGripper, World
from drivers.sim.devices.arm import KinematicArm
from drivers.sim.devices.gripper import SimGripper
from drivers.sim.models.plate import BeamPlate
from drivers.sim.scenes import SCENES
from fvfiles.errors import FvtreeError

DESIGN_FILE = Path(__file__).resolve().parents[2] / "trees" / "design" / "two_bays.json"
HOME = [0.0, 0.0, 0.5, np.pi, 0.0, 0.0]


class _Door:
    """A back door that accepts every request (no emulator behind it)."""

    where = "test"

    def call(self, line: str) -> dict:
        return {"ok": True}


def _scene_args() -> dict:
    return DesignModel.load(DESIGN_FILE).scene_args()


@pytest.mark.parametrize("name", sorted(SCENES))
def test_every_scene_is_a_world(name):
    arm, gripper = KinematicArm(SimClock(1 / 30), HOME), SimGripper()
    world = SCENES[name](arm, gripper, _scene_args() if name == "assembly" else {}, {}, 0)
    assert isinstance(world, World)
    world.step(1 / 30)
    assert set(world.contacts()) == {"left", "right"}
    assert isinstance(world.metrics(), dict) and isinstance(world.truth(), dict)


def test_simulated_and_followed_devices_are_what_a_scene_needs():
    arm, gripper = KinematicArm(SimClock(1 / 30), HOME), SimGripper()
    assert isinstance(arm, SceneArm) and isinstance(gripper, SceneGripper)
    followed_arm = FollowedArm(arm, _Door())
    followed_gripper = FollowedGripper(gripper, _Door(), pad_stiffness=5000.0)
    assert isinstance(followed_arm, SceneArm) and isinstance(followed_gripper, SceneGripper)
    world = SCENES["assembly"](followed_arm, followed_gripper, _scene_args(), {}, 0)
    world.step(1 / 30)
    assert isinstance(world, World)


def test_assembly_plates_take_their_loads_from_the_scene_file_next_to_the_design():
    args = _scene_args()
    assert args["design_file"] == str(DESIGN_FILE)
    assert all("sim_load" not in plate for plate in args["plates"])
    cell = load_cell("sim", 30, "assembly", args)
    assert cell.world.plates["P1"].beam == BeamPlate(span=1.0, EI=50.0, w=80.0, P=120.0, c=0.78, k=2000.0)
    assert cell.world.plates["P2"].beam.P == 100.0 and cell.world.plates["P2"].beam.c == 0.25


def _design_copy(tmp_path: Path, scene: str | None) -> dict:
    """Scene args of a copy of the two-bay design with the scene file `scene` (None: none)."""
    design = tmp_path / "bays.json"
    shutil.copy(DESIGN_FILE, design)
    if scene is not None:
        (tmp_path / "bays.scene.yaml").write_text(scene)
    return DesignModel.load(design).scene_args()


def test_without_a_scene_file_the_plates_take_the_beam_defaults(tmp_path):
    cell = load_cell("sim", 30, "assembly", _design_copy(tmp_path, None))
    assert cell.world.plates["P1"].beam == BeamPlate(span=1.0)


def test_a_plate_left_out_of_the_scene_file_takes_the_defaults(tmp_path):
    cell = load_cell("sim", 30, "assembly", _design_copy(tmp_path, "plates:\n  P1: {P: 90.0}\n"))
    assert cell.world.plates["P1"].beam == BeamPlate(span=1.0, P=90.0)
    assert cell.world.plates["P2"].beam == BeamPlate(span=1.0)


@pytest.mark.parametrize("text, field, line, message, hint", [
    ("plates:\n  P1: {EI: 50.0, EJ: 3}\n", "plates.P1.EJ", 2, "unknown field", "EI"),
    ("plates:\n  P1: {EI: 50.0}\n  P3: {w: 1.0}\n", "plates.P3", 3, "no plate 'P3'", "P1"),
    ("plates:\n  P1:\n    EI: -5\n", "plates.P1.EI", 3, "must be positive", None),
    ("plates:\n  P1:\n    c: 1.4\n", "plates.P1.c", 3, "on the span", None),
    ("plates:\n  P1:\n    w: heavy\n", "plates.P1.w", 3, "must be a number", None),
    ("plates:\n  P1: [1, 2]\n", "plates.P1", 2, "must be a mapping", None),
    ("plate:\n  P1: {}\n", "plate", 1, "unknown field", "plates"),
    ("plates: [\n", None, 2, "malformed YAML", None),
])
def test_a_malformed_scene_file_is_a_located_error(tmp_path, text, field, line, message, hint):
    args = _design_copy(tmp_path, text)
    with pytest.raises(FvtreeError) as err:  # CellFileError, or the YAML reader's SourceError
        load_cell("sim", 30, "assembly", args)
    assert err.value.file == str(tmp_path / "bays.scene.yaml")
    assert (err.value.field, err.value.line) == (field, line) and message in err.value.message
    assert hint is None or hint in err.value.hint


def test_assembly_truth_is_per_standing_element_with_its_true_load_curve():
    cell = load_cell("sim", 30, "assembly", _scene_args())
    world = cell.world
    assert world.truth() == {} and world.metrics() == {}
    e1, p1 = world.elements["E1"], world.plates["P1"]
    a = 0.5  # stand E1 upright under P1, half way along, its top touching the plate's soffit
    e1.pose = np.array([p1.origin[0] + a, p1.origin[1], p1.origin[2] - e1.length / 2, 0.0, -np.pi / 2, 0.0])
    e1.state = "standing"
    truth = world.truth()
    assert set(truth) == {"E1"}
    t = truth["E1"]
    a_best, r_best = p1.beam.max_load(0.0)
    assert t["plate"] == "P1" and t["position"] == pytest.approx(a)
    assert (t["true_best_position"], t["true_max_load_N"]) == pytest.approx((a_best, r_best))
    assert t["load_N"] == pytest.approx(float(p1.beam.carried_force(a, 0.0)))
    assert t["regret"] == pytest.approx((r_best - t["load_N"]) / r_best)
    curve = t["true_load_curve"]
    assert curve["load_N"].max() == pytest.approx(r_best, rel=1e-4)
    assert json.dumps({k: v for k, v in t.items() if k != "true_load_curve"})  # plain numbers


def test_the_fingers_grasp_only_the_element_they_hold():
    """With E2 in the hand, E1 standing across the fingers is not grasped as well."""
    arm, gripper = KinematicArm(SimClock(1 / 30), HOME), SimGripper(gel_stiffness=5000.0)
    world = SCENES["assembly"](arm, gripper, _scene_args(), {}, 0)
    e1, e2 = world.elements["E1"], world.elements["E2"]
    arm._pose[:3] = e2.pose[:3]
    gripper.move(0.0, speed=0.1, force=20.0)
    for _ in range(30):
        world.step(1 / 30)
    assert e2.state == "held"
    e1.state = "standing"
    e1.pose = np.array([*arm.pose()[:3], 0.0, -np.pi / 2, 0.0])  # upright, its middle between the fingers
    world.step(1 / 30)
    assert e1.state == "standing" and e2.state == "held"
