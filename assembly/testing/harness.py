"""Tick-by-tick testing of trees with mocked perception, for tree authors.

    h = TreeHarness.from_text(TREE_YAML)                 # or TreeHarness.from_file("trees/x.yaml")
    h.script(lambda tick, t: {"left": touch("left", normal=5.0), "right": touch("right", normal=5.0)})
    h.tick(3)
    h.assert_status({"root/grasp": "RUNNING"})
    h.run_until_done(max_ticks=500)
    assert h.blackboard("/task/grasp_width") > 0.03
    assert h.arm.commands_named("move_linear")

Any node can be replaced by a test double, by path or glob (`assembly.language.substitution`):

    h = TreeHarness.from_file("trees/assembly.yaml", cell=cell, substitute={"*/pick_once/grasp": "running:3:success"})

The mocked cell is a kinematic arm (behind the real safety layer) and a gripper that record
every command; perception comes from a script: a function of (tick, time), or a table of rows
`(from_tick, {finger: touch(...)})`. `TreeHarness.from_text(..., cell=load_cell(...))` runs the same
tree on the full simulated cell instead, optionally with scripted perception on top.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from py_trees.blackboard import Blackboard
from py_trees.common import Status

from assembly.design.model import DesignModel
from assembly.language.build import BuiltTree
from assembly.language.reader import TreeDocument, load_tree
from assembly.language.substitution import Rule, rules_from
from assembly.run.options import RunOptions
from assembly.run.session import Run
from drivers.cell import Cell
from drivers.clock import SimClock
from drivers.protocols import Arm, Gripper
from drivers.safe_gripper import SafeGripper
from drivers.safety import SafeArm, SafetyLimits
from drivers.sim.devices.arm import KinematicArm
from drivers.sim.devices.gripper import SimGripper
from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.scenes.base import Scene
from drivers.sim.scenes.grip import empty_contacts
from fvfiles.errors import did_you_mean
from perception.state import FINGERS, ObjectInfo, TactileState

Substitutions = dict[str, str | dict] | list[Rule] | None  # {PATH or glob: SPEC} or rules

HOME = np.array([0.0, 0.0, 0.5, np.pi, 0.0, 0.0])

_models: dict[str, SensorModel] = {}


def touch(finger: str, normal: float = 0.0, shear=(0.0, 0.0), torque: float = 0.0,
          area: float = 0.0, centroid=(0.0, 0.0), orientation: float = 0.0, slip: float = 0.0,
          stamp: float = 0.0, healthy: bool = True) -> TactileState:
    """A noise-free TactileState whose marker field matches the given loads (N, N m) and
    object view, produced by the simulator's FingerVision contact model."""
    model = _models.get(finger) or _models.setdefault(finger, SensorModel(finger, noise_px=0.0))
    obj = ObjectInfo(area > 0.0, area, np.asarray(centroid, float), orientation)
    state = model.state(FingerContact(normal, np.asarray(shear, float), torque, None, obj, slip), stamp)
    if not healthy:
        state = TactileState(finger, stamp, state.markers, state.force, state.torque, obj, slip,
                             False, "scripted as unhealthy")
    return state


@dataclass
class Command:
    t: float
    name: str
    args: tuple


class RecordingArm(SafeArm):
    """The safety layer's arm that also records every command sent to it with the cell time."""

    def __init__(self, arm: Arm, limits: SafetyLimits, clock: SimClock):
        super().__init__(arm, limits, clock)
        self.commands: list[Command] = []

    def move_linear(self, pose: np.ndarray, speed: float) -> None:
        self.commands.append(Command(self.clock.now(), "move_linear", (pose, speed)))
        super().move_linear(pose, speed)

    def speed_linear(self, twist: np.ndarray) -> None:
        self.commands.append(Command(self.clock.now(), "speed_linear", (twist,)))
        super().speed_linear(twist)

    def stop(self) -> None:
        self.commands.append(Command(self.clock.now(), "stop", ()))
        super().stop()

    def commands_named(self, name: str) -> list[Command]:
        return [c for c in self.commands if c.name == name]


class RecordingGripper(SafeGripper):
    """The safety layer's gripper that also records every command sent to it with the cell time."""

    def __init__(self, gripper: Gripper, clock: SimClock):
        super().__init__(gripper)
        self.clock = clock
        self.commands: list[Command] = []

    def move(self, width: float, speed: float = 0.05, force: float = 20.0) -> None:
        self.commands.append(Command(self.clock.now(), "move", (width, speed, force)))
        super().move(width, speed, force)

    def stop(self) -> None:
        self.commands.append(Command(self.clock.now(), "stop", ()))
        super().stop()

    def commands_named(self, name: str) -> list[Command]:
        return [c for c in self.commands if c.name == name]


class _MockWorld(Scene):
    """The least a mocked cell needs: integrate arm and gripper, feel nothing."""

    def __init__(self, arm, gripper):
        self.arm, self.gripper = arm, gripper

    def step(self, dt: float) -> None:
        self.arm.step(dt)
        self.gripper.step(dt)

    def contacts(self) -> dict:
        return empty_contacts()


def mock_cell(tick_hz: float = 30.0, home=HOME, gripper_width: float = 0.085,
              object_width: float | None = None, limits: SafetyLimits | None = None) -> Cell:
    """A cell with a kinematic arm and gripper, both behind the real safety layer, that record
    commands and perceive nothing; `object_width` puts an object of that width between the fingers."""
    clock = SimClock(1.0 / tick_hz)
    raw_arm = KinematicArm(clock, home)
    raw_gripper = SimGripper(width=gripper_width, gel_stiffness=5000.0)
    raw_gripper.object_width = object_width
    arm = RecordingArm(raw_arm, limits or SafetyLimits(), clock)
    gripper = RecordingGripper(raw_gripper, clock)
    empty = {f: touch(f) for f in FINGERS}
    return Cell("mock", arm, gripper, clock, lambda: empty, world=_MockWorld(raw_arm, raw_gripper))


Script = Callable[[int, float], dict]


def table(rows: Iterable[tuple[int, dict]]) -> Script:
    """A script from rows (from_tick, {finger: TactileState}); each row holds until the next."""
    rows = sorted(rows, key=lambda r: r[0])

    def script(tick: int, t: float) -> dict:
        current = {}
        for start, states in rows:
            if start > tick:
                break
            current = states
        return current
    return script


class TreeHarness:
    """A tree ticked by hand on a mocked (or simulated) cell with scripted perception: a `Run`
    without run directory, recording or supervisor, whose perception comes from the script."""

    def __init__(self, doc: TreeDocument, cell: Cell | None = None, design: DesignModel | None = None,
                 substitute: Substitutions = None):
        if design is not None:
            doc = replace(doc, design=design)
        rules = tuple(rules_from(substitute or {}, "TreeHarness"))
        options = RunOptions(runs_dir=None, record=False, plots=False, quiet=True, supervised=False,
                             substitutions=rules)
        self._script: Script | None = None
        self._run = Run(doc, options, cell=cell or mock_cell(doc.tick_hz), sense=self._sense).open()
        self.tree: BuiltTree = self._run.tree
        self.cell: Cell = self._run.cell
        self.design: DesignModel | None = doc.design
        self.substitutions: list[dict] = self._run.substituted  # what was replaced: path, was, double

    @classmethod
    def from_text(cls, text: str, cell: Cell | None = None, design: DesignModel | None = None,
                  name: str = "<test tree>", substitute: Substitutions = None) -> TreeHarness:
        return cls(load_tree(text=text, name=name, dataflow=False), cell, design, substitute)

    @classmethod
    def from_file(cls, path: str | Path, cell: Cell | None = None,
                  design: DesignModel | None = None, substitute: Substitutions = None) -> TreeHarness:
        return cls(load_tree(path, dataflow=False), cell, design, substitute)

    @classmethod
    def load(cls, doc: TreeDocument, cell: Cell | None, design: DesignModel | None,
             substitute: Substitutions = None) -> TreeHarness:
        """`substitute` replaces nodes by path or glob with test doubles: `{PATTERN: SPEC}` or
        `Rule`s (`assembly.language.substitution`); `harness.substitutions` lists what was replaced."""
        return cls(doc, cell, design, substitute)

    # ---- perception ------------------------------------------------------------------------
    def script(self, script: Script | list) -> TreeHarness:
        """Script perception: a function (tick, time) -> {finger: TactileState}, or table rows.
        Fingers the script leaves out come from the cell (the simulated world, or nothing)."""
        self._script = table(script) if isinstance(script, list) else script
        return self

    def _sense(self, cell: Cell) -> dict:
        states = dict(cell.sense())
        if self._script is not None:
            states.update(self._script(self._run.ticks, cell.clock.now()))
        return states

    # ---- ticking ---------------------------------------------------------------------------
    def tick(self, n: int = 1) -> Status:
        for _ in range(n):
            status = self._run.tick()
        return status

    def run_until_done(self, max_ticks: int = 10_000) -> Status:
        """Tick until the root leaves RUNNING; AssertionError if it never does."""
        for _ in range(max_ticks):
            status = self.tick()
            if status != Status.RUNNING:
                return status
        raise AssertionError(f"tree still RUNNING after {max_ticks} ticks at {self.tip()}")

    def halt(self) -> None:
        """What Ctrl-C does: stop every running node, the arm and the gripper (and, on a simulated
        cell, let them come to rest)."""
        self._run.halt()

    def settle(self) -> None:
        """Step the cell, not the tree, until the arm and the gripper are at rest (at most 2 s): a
        stopped arm brakes over its latency and deceleration before it stands."""
        self._run.runner.come_to_rest()

    @property
    def ticks(self) -> int:
        return self._run.ticks

    # ---- inspection ------------------------------------------------------------------------
    @property
    def arm(self) -> SafeArm:
        """The cell's arm: on a mocked cell a `RecordingArm`, which records every command."""
        return self.cell.arm

    @property
    def gripper(self) -> SafeGripper:
        """The cell's gripper: on a mocked cell a `RecordingGripper`, which records every command."""
        return self.cell.gripper

    def node(self, path: str):
        try:
            return self.tree.nodes[path]
        except KeyError:
            hint = did_you_mean(path, self.tree.nodes)
            raise KeyError(f"no node at {path!r}" + (f"; {hint}" if hint else "")) from None

    def status(self, path: str) -> str:
        return self.node(path).status.name

    def feedback(self, path: str) -> str:
        return self.node(path).feedback_message

    def assert_status(self, expected: dict[str, str]) -> None:
        """Compare node statuses by path, reporting every mismatch at once."""
        wrong = {p: (s, self.status(p)) for p, s in expected.items() if self.status(p) != s.upper()}
        if wrong:
            lines = [f"  {p}: expected {e}, got {g} ({self.feedback(p)!r})" for p, (e, g) in wrong.items()]
            raise AssertionError(f"after tick {self.ticks}:\n" + "\n".join(lines))

    def tip(self) -> str:
        tip = self.tree.root.tip()
        return self.tree.path_of(tip) if tip is not None else ""

    def blackboard(self, key: str, default: Any = None) -> Any:
        return Blackboard.storage.get(key, default)

    def set(self, key: str, value: Any) -> None:
        """Preset a blackboard value (e.g. /task/element for a skill under test)."""
        Blackboard.set(key, value)
