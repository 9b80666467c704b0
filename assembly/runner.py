"""The tick loop: perception stage, one tree tick, watchdog kick, transition log, cell step.

Every tick: the perception stage writes /fv/left, /fv/right, /robot/*, /gripper/* and
/task/estop; the tree ticks once; status changes go to the JSON-lines transition log; the cell
advances one period of its clock (simulated time, or a sleep to the next period on a real cell).
Ctrl-C or an e-stop halts the tree: every running skill's `terminate` runs and the arm stops.
"""

from __future__ import annotations

import gc
import json
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, TextIO

import numpy as np
import py_trees
from py_trees.blackboard import Blackboard
from py_trees.common import Status

from assembly.design import DesignBridge
from assembly.loader import BuiltTree
from behaviours import keys
from drivers.cell import Cell


@dataclass
class RunResult:
    status: str  # SUCCESS | FAILURE | HALTED | ESTOP | TIMEOUT
    ticks: int
    sim_time: float
    wall_time: float
    where: str  # node path where the run ended or stopped
    message: str = ""
    profiles: dict[str, dict] = field(default_factory=dict)  # element -> load profile

    @property
    def real_time_factor(self) -> float:
        return self.sim_time / self.wall_time if self.wall_time > 0 else float("inf")


class TransitionLog:
    """JSON lines: tick, sim time, node path, old -> new status, feedback. Flushed per tick."""

    def __init__(self, path: Path | None):
        self._file: TextIO | None = open(path, "a") if path else None

    def write(self, records: list[dict]) -> None:
        if self._file and records:
            self._file.write("".join(json.dumps(r) + "\n" for r in records))
            self._file.flush()

    def close(self) -> None:
        if self._file:
            self._file.flush()
            os.fsync(self._file.fileno())
            self._file.close()
            self._file = None


def publish_perception(cell: Cell, states: dict | None = None) -> None:
    """The perception stage: write this tick's tactile, robot and gripper state.

    It is the only writer of these keys, so it stores them directly (py_trees' checked
    `Blackboard.set` would cost more than the rest of the stage); skills read them through
    clients registered with READ access.
    """
    states = cell.sense() if states is None else states
    arm, gripper = cell.arm, cell.gripper
    Blackboard.storage.update({
        keys.FV_LEFT: states["left"],
        keys.FV_RIGHT: states["right"],
        keys.ROBOT_POSE: arm.pose(),
        keys.ROBOT_WRENCH: arm.tcp_wrench(),
        keys.ROBOT_FAULT: arm.fault(),
        keys.ROBOT_MOVING: arm.is_moving(),
        keys.GRIPPER_WIDTH: gripper.width(),
        keys.GRIPPER_OBJECT: gripper.object_detected(),
        keys.GRIPPER_FAULT: gripper.fault(),
        keys.GRIPPER_MOVING: gripper.is_moving(),
        keys.ESTOP: cell.estop,
    })


class Runner:
    """Runs a built tree on a cell, tick by tick."""

    def __init__(self, tree: BuiltTree, cell: Cell, run_dir: Path | None = None,
                 bridge: DesignBridge | None = None, realtime: bool = False,
                 progress: Callable[[str], None] | None = None,
                 sense: Callable[[], dict] | None = None):
        self.tree = tree
        self.cell = cell
        self.run_dir = run_dir
        self.bridge = bridge
        self.realtime = realtime
        self.progress = progress
        self.sense = sense or cell.sense
        self.ticks = 0
        self.log = TransitionLog(run_dir / "transitions.jsonl" if run_dir else None)
        self._nodes = list(tree.nodes.items())
        self._last = {path: Status.INVALID for path, _ in self._nodes}
        self.profiles: dict[str, dict] = {}
        self._profile = None
        self.tip_path = ""
        self._previous_tip = ""  # the tip before the last change: where an e-stop interrupted
        self.estop_file = run_dir / "ESTOP" if run_dir else None
        self.estop_at: float | None = None
        self.setup()

    def setup(self) -> None:
        design = self.tree.document.design if self.bridge is None else self.bridge.model
        for node in self.tree.root.iterate():
            node.setup(cell=self.cell, design=design, bridge=self.bridge)

    # ---- one tick --------------------------------------------------------------------------
    def tick(self) -> Status:
        now = self.cell.clock.now()
        if self.estop_at is not None and now >= self.estop_at:
            self.cell.estop = True
        publish_perception(self.cell, self.sense())
        self.tree.root.tick_once()
        self.cell.arm.kick()
        self._record(now)
        self.ticks += 1
        self.cell.step()
        return self.tree.root.status

    def _record(self, now: float) -> None:
        changes = []
        for path, node in self._nodes:
            status = node.status
            if status is not self._last[path]:
                changes.append({"tick": self.ticks, "t": round(now, 6), "node": path,
                                "from": self._last[path].name, "to": status.name,
                                "feedback": node.feedback_message})
                self._last[path] = status
        self.log.write(changes)
        profile = Blackboard.storage.get(keys.LOAD_PROFILE)
        if profile is not None and profile is not self._profile:
            self._profile = profile
            element = Blackboard.storage.get(keys.ELEMENT, {}).get("id", f"#{len(self.profiles)}")
            self.profiles[element] = profile
        if changes:
            tip = self.tree.root.tip()
            path = self.tree.path_of(tip) if tip is not None else self.tip_path
            if path != self.tip_path:
                self._previous_tip, self.tip_path = self.tip_path, path
                if self.progress:
                    element = Blackboard.storage.get(keys.ELEMENT, {}) or {}
                    self.progress(f"t={now:7.2f}s  {element.get('id', '-'):>4}  {path}")

    # ---- the loop --------------------------------------------------------------------------
    def run(self, max_time: float = 3600.0) -> RunResult:
        """Tick until the root succeeds or fails, `max_time` of cell time passes, Ctrl-C, or e-stop."""
        # Collect once, then keep every object alive so far out of the garbage collector's
        # view: a full collection over them pauses the tick loop for 100 ms or more.
        gc.collect()
        gc.freeze()
        start = time.perf_counter()
        status, message = Status.RUNNING, ""
        try:
            while status == Status.RUNNING:
                status = self.tick()
                if self.cell.estop or (self.estop_file and self.ticks % 8 == 0 and self.estop_file.exists()):
                    self.cell.estop = True
                    interrupted = self._previous_tip
                    self.halt()
                    self.tip_path = interrupted
                    return self._result("ESTOP", start, f"e-stop requested during {interrupted}")
                if self.cell.clock.now() > max_time:
                    self.halt()
                    return self._result("TIMEOUT", start, f"no result within {max_time} s of cell time")
                if self.realtime and self.cell.simulated:
                    self._pace(start)
        except KeyboardInterrupt:
            self.halt()
            return self._result("HALTED", start, "interrupted (Ctrl-C)")
        finally:
            self.log.close()
            gc.unfreeze()
        if status == Status.FAILURE:
            message = self._failure_message()
        return self._result(status.name, start, message)

    def _pace(self, start: float) -> None:
        ahead = self.cell.clock.now() - (time.perf_counter() - start)
        if ahead > 0:
            time.sleep(ahead)

    def halt(self) -> None:
        """Stop the tree (every running skill's terminate runs) and the arm."""
        tip = self.tree.root.tip()
        if tip is not None:
            self.tip_path = self.tree.path_of(tip)
        self.tree.root.stop(Status.INVALID)
        self.cell.arm.stop()
        self.cell.gripper.stop()
        self._record(self.cell.clock.now())
        if self.bridge:
            self.bridge.event("halted", node=self.tip_path, estop=self.cell.estop)

    def _failure_message(self) -> str:
        """The feedback of the deepest failed node: why the tree failed."""
        failed = [(p, n) for p, n in self._nodes if n.status == Status.FAILURE and n.feedback_message]
        if not failed:
            return ""
        path, node = max(failed, key=lambda pn: pn[0].count("/"))
        self.tip_path = path
        return node.feedback_message

    def _result(self, status: str, start: float, message: str) -> RunResult:
        return RunResult(status, self.ticks, self.cell.clock.now(), time.perf_counter() - start,
                         self.tip_path, message, self.profiles)


def new_run_dir(base: Path, tree_name: str) -> Path:
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for i in range(1000):
        path = base / (f"{stamp}-{tree_name}" + (f"-{i}" if i else ""))
        try:
            path.mkdir(parents=True)
            return path
        except FileExistsError:
            continue
    raise RuntimeError(f"cannot create a run directory under {base}")


def stderr_progress(line: str) -> None:
    if sys.stderr.isatty():
        sys.stderr.write("\r\033[K" + line[:150])
    else:
        sys.stderr.write(line + "\n")
    sys.stderr.flush()


def clear_blackboard() -> None:
    """Forget every key and client (the blackboard is process-global in py_trees)."""
    py_trees.blackboard.Blackboard.clear()

