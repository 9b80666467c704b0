"""The recipes of CONTRIBUTING.md, done once each: a new skill, a new scene and a new cell driver.
(A new node kind is done in tests/test_node_kinds.py.)"""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from assembly.testing import TreeHarness, mock_cell
from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill
from behaviours.skill_kit.registry import SKILLS
from drivers.cell import Cell
from drivers.cell_builders import BUILDERS, CellRequest, load_cell
from drivers.protocols import World
from drivers.sim.scenes import SCENES
from drivers.sim.scenes.base import Scene
from drivers.sim.scenes.grip import empty_contacts


# ---- a skill: behaviours/nod.py would hold this class, imported in behaviours/__init__.py --------
class Nod(ProgramSkill):
    """Lower the tool by `depth` and come back: the smallest skill that moves the arm."""

    NAME = "nod"
    SUMMARY = "lower the tool and raise it again"
    PARAMS = {"depth": Param("float", "how far to lower the tool", 0.02, "m", min=0.0, max=0.1)}
    READS = (keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING)

    def program(self):
        start = self.pose()
        for target in (start - [0, 0, self.p.depth, 0, 0, 0], start):
            fault = yield from self.move(target, 0.05, timeout=5.0)
            if fault:
                return self.fail(fault)
        return Status.SUCCESS


def test_adding_a_skill(monkeypatch):
    monkeypatch.setitem(SKILLS, Nod.NAME, Nod)  # what @register does
    h = TreeHarness.from_text("version: 1\nname: nod\nroot: {skill: nod, params: {depth: 0.03}}\n")
    assert h.run_until_done(max_ticks=300) == Status.SUCCESS
    lowest = min(c.args[0][2] for c in h.arm.commands_named("move_linear"))
    assert np.isclose(lowest, 0.5 - 0.03)


# ---- a scene: drivers/sim/scenes/bell.py would hold this, with an entry in SCENES ----------------
class BellScene(Scene):
    """A bell under the tool: it rings (counts) each time the tool dips below `height`."""

    def __init__(self, arm, gripper, height: float):
        self.arm, self.gripper, self.height = arm, gripper, height
        self.rings, self._below = 0, False

    def step(self, dt: float) -> None:
        self.arm.step(dt)
        self.gripper.step(dt)
        below = self.arm.pose()[2] < self.height
        self.rings += below and not self._below
        self._below = below

    def contacts(self):
        return empty_contacts()

    def metrics(self) -> dict:
        return {"rings": self.rings}


def build_bell(arm, gripper, args: dict, world: dict, seed: int) -> BellScene:
    return BellScene(arm, gripper, args.get("height", 0.49))


def test_adding_a_scene(monkeypatch):
    monkeypatch.setitem(SCENES, "bell", build_bell)
    cell = load_cell("sim", 30, "bell", {"height": 0.49})
    assert isinstance(cell.world, World)
    h = TreeHarness.from_text("version: 1\nname: ring\ncell: {scene: bell}\n"
                              "root: {skill: move_to, params: {offset: [0, 0, -0.02]}}\n", cell=cell)
    assert h.run_until_done(max_ticks=300) == Status.SUCCESS
    assert cell.world.metrics() == {"rings": 1}


# ---- a cell driver: a module with build(path, data, request) -> Cell, and a BUILDERS entry -------
def build_bench_cell(path, data, request: CellRequest) -> Cell:
    """A 'bench' cell: the mock devices, with the gripper opening taken from the cell file."""
    if not isinstance(data.get("opening"), (int, float)):
        from drivers.cell_file import CellFileError

        raise CellFileError(path, "opening", "must be a number of metres")
    return mock_cell(request.tick_hz, gripper_width=float(data["opening"]))


def test_adding_a_cell_driver(monkeypatch, tmp_path):
    monkeypatch.setitem(BUILDERS, "bench", f"{__name__}:build_bench_cell")
    path = tmp_path / "bench.yaml"
    path.write_text("kind: bench\nopening: 0.05\n")
    cell = load_cell(str(path), 50)
    assert cell.gripper.width() == 0.05 and cell.clock.period == 1 / 50
    path.write_text("kind: bench\nopening: wide\n")
    try:
        load_cell(str(path), 50)
    except Exception as exc:  # noqa: BLE001 - the driver's own check, located in the file
        assert str(exc) == f"{path}:2: opening: must be a number of metres"
    else:
        raise AssertionError("a bad cell file was accepted")
