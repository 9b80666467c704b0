"""The cell supervisor: once per tick, right after the perception stage and before the tree acts
on the snapshot, anything that makes the cell unfit to move latches a stop of arm AND gripper
(`trip`) and ends the run with status FAULT, the cause and the node that was running.

Causes, in the order they are checked: an arm fault (driver, protective stop, e-stop, the force
limit or watchdog latched by `SafeArm`), a gripper fault, a lost link (arm state older than the
arm's `stale_after`), the snapshot's TCP force over the arm's `max_force` (or not finite), fingertip
perception older than `perception_stale_after` (`TactileState.stamp` against the cell clock),
and unhealthy perception (`TactileState.healthy`).

Unhealthy perception is configurable per cell (`unhealthy_perception` in the cell file's
`supervision:` section): `stop` (default) stops the cell whatever runs; `fail` leaves it to the
skills: a skill that reads /fv/left or /fv/right (declared in its READS) stops arm and gripper
and fails with the reason (`ProgramSkill.update`), so the tree may go on (a fallback, a move
home), while skills that need no touch run on.

On a wall-clock cell the runner first waits (up to 5 s) for fresh perception, so that frames from
before the run do not stop its first tick; every run's worst tick gap and data ages, beside their
limits, end up in its summary (`Margins`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, fields
from pathlib import Path

import py_trees
from py_trees.blackboard import Blackboard

from assembly.language.build import BuiltTree
from assembly.run.stop_policy import Stop
from assembly.run.tip import Tip
from behaviours.skill_kit import keys
from drivers.cell import Cell
from drivers.cell_file import CellFileError, read_cell_file, resolve_cell_path, section
from drivers.protocols import PerceptionSource
from perception.state import FINGERS

UNHEALTHY_POLICIES = ("stop", "fail")
TACTILE_KEYS = (keys.FV_LEFT, keys.FV_RIGHT)
WARM_UP_S = 5.0  # s a wall-clock cell may take to deliver fresh perception before the first tick


@dataclass(frozen=True)
class Supervision:
    """What the supervisor watches for, from the cell file's `supervision:` section."""

    perception_stale_after: float = 0.2  # s: older fingertip states stop the cell
    unhealthy_perception: str = "stop"  # stop | fail (see the module docstring)

    @classmethod
    def of_cell(cls, name_or_path: str) -> Supervision:
        """The `supervision:` section of a cell file (a path or a packaged cell's name), checked."""
        path = resolve_cell_path(name_or_path)
        values = section(path, read_cell_file(path), "supervision", known=[f.name for f in fields(cls)])
        return cls.from_section(path, values)

    @classmethod
    def from_section(cls, path: Path, values: dict) -> Supervision:
        """Settings from a checked `supervision:` mapping; CellFileError naming a bad value."""
        stale = values.get("perception_stale_after", cls.perception_stale_after)
        if isinstance(stale, bool) or not isinstance(stale, (int, float)) or not math.isfinite(stale) or stale <= 0:
            raise CellFileError(path, "supervision.perception_stale_after",
                                f"must be a positive number of seconds, got {stale!r}")
        policy = values.get("unhealthy_perception", cls.unhealthy_perception)
        if policy not in UNHEALTHY_POLICIES:
            raise CellFileError(path, "supervision.unhealthy_perception",
                                f"must be one of {', '.join(UNHEALTHY_POLICIES)}, got {policy!r}")
        return cls(float(stale), policy)


class Margins:
    """The worst of what the supervisor measured over a run, beside the limit it holds each to: how
    close a run came to a stop for nothing (a loaded machine's tick gaps and data ages), so that a
    lab can set its cell file's limits from measured figures (`summary.json`'s `margins`)."""

    def __init__(self, arm_stale_after: float, perception_stale_after: float, watchdog_timeout: float):
        self.limits = {"arm_state_age_s": arm_stale_after, "perception_age_s": perception_stale_after,
                       "tick_gap_s": watchdog_timeout}
        self.worst = dict.fromkeys(self.limits, 0.0)
        self._last_tick: float | None = None

    def tick(self, now: float) -> None:
        if self._last_tick is not None and now - self._last_tick > self.worst["tick_gap_s"]:
            self.worst["tick_gap_s"] = now - self._last_tick
        self._last_tick = now

    def saw(self, what: str, age: float) -> None:
        self.worst[what] = max(self.worst[what], age)

    def report(self) -> dict[str, dict[str, float]]:
        """{measure: {"worst": s, "limit": s}}, rounded to the millisecond."""
        return {k: {"worst": round(self.worst[k], 3), "limit": self.limits[k]} for k in self.limits}


class Supervisor:
    """Pre-tick handler (after the perception stage) that latches a stop on the first cause,
    and a `StopPolicy` check that then ends the run with status FAULT."""

    def __init__(self, cell: Cell, settings: Supervision, tree: BuiltTree, tip: Tip):
        self.cell = cell
        self.settings = settings
        self.tree = tree
        self.tip = tip
        self.cause: str | None = None  # the latched cause
        self.tripped_at: float | None = None  # cell time of the trip
        self._running = ""  # the node running when the cause was found
        self.margins = Margins(cell.arm.limits.stale_after, settings.perception_stale_after,
                               cell.arm.limits.watchdog_timeout)

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        if self.cause is not None:
            return
        cause = self.find_cause()
        if cause is not None:
            self.latch(cause)

    def await_fresh_perception(self, sense: PerceptionSource, timeout: float = WARM_UP_S) -> None:
        """Before the first tick on a wall-clock cell: read perception until every fingertip's
        state is healthy and within the staleness limit (at most `timeout` s), so that the first
        tick does not stop the cell on a frame from before the run (calibration, setting the tree
        up) or a camera still starting. What is still stale or unhealthy then trips the first tick
        as ever."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            states, now = sense(), self.cell.clock.now()
            if all(f in states and states[f].healthy and now - states[f].stamp <= self.settings.perception_stale_after
                   for f in FINGERS):
                return
            time.sleep(0.01)

    def latch(self, cause: str) -> None:
        """Trip arm and gripper (both stop, both refuse commands until a person resets them)."""
        self.cause, self.tripped_at, self._running = cause, self.cell.clock.now(), self.tip.path
        self.cell.arm.trip(f"cell supervisor: {cause}")
        self.cell.gripper.trip(f"cell supervisor: {cause}")

    def check(self) -> Stop | None:
        """After the tick: the FAULT stop once a cause is latched. A cause found before the first
        node ran names the node that tick started."""
        if self.cause is None:
            return None
        where = self._running or self.tip.path
        return Stop("FAULT", f"{self.cause} (during {where})", where)

    # ---- the causes ------------------------------------------------------------------------
    def find_cause(self) -> str | None:
        """The first reason the cell may not go on, or None."""
        arm, gripper = self.cell.arm, self.cell.gripper
        fault = arm.fault()
        if fault:
            return f"arm fault: {fault}"
        fault = gripper.fault()
        if fault:
            return f"gripper fault: {fault}"
        now = self.cell.clock.now()
        self.margins.tick(now)
        age = now - arm.state_stamp()
        self.margins.saw("arm_state_age_s", age)
        if not age <= arm.limits.stale_after:
            return f"link to the arm lost: its state is {age:.3f} s old (limit {arm.limits.stale_after} s)"
        # The wrench the perception stage just read through the arm's safety layer (a second read costs
        # as much again): the force the tree is about to act on.
        force = math.hypot(*Blackboard.storage[keys.ROBOT_WRENCH][:3].tolist())
        if not force <= arm.limits.max_force:
            return f"force over the limit: {force:.1f} N > {arm.limits.max_force:.1f} N"
        return self._perception_cause(now)

    def _perception_cause(self, now: float) -> str | None:
        storage = Blackboard.storage
        for key in TACTILE_KEYS:
            state = storage.get(key)
            if state is None:
                return f"no perception on {key}"
            age = now - state.stamp
            self.margins.saw("perception_age_s", age)
            if not age <= self.settings.perception_stale_after:
                return (f"perception on {key} is {age:.3f} s old "
                        f"(limit {self.settings.perception_stale_after} s)")
        if self.settings.unhealthy_perception == "stop":
            for key in TACTILE_KEYS:
                state = storage[key]
                if not state.healthy:
                    return f"perception on {key} is unhealthy: {state.health_reason or 'no reason given'}"
        return None
