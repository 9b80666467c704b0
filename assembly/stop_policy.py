"""When a run stops before its tree finishes, and how it stops.

A run stops on an e-stop (the cell's input, an `ESTOP` file in the run directory, or one
scheduled at a cell time), when its cell-time limit passes, or on Ctrl-C. Stopping halts the
tree: every running skill's `terminate` runs, the arm and the gripper stop and the design
bridge hears of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import py_trees
from py_trees.common import Status

from assembly.design import DesignBridge
from assembly.tip import Tip
from drivers.cell import Cell


@dataclass(frozen=True)
class Stop:
    """Why a run stopped: the result status, its message, and the node to name (None: the tip
    when the tree was halted)."""

    status: str  # ESTOP | TIMEOUT | HALTED
    message: str
    where: str | None = None


class StopPolicy:
    """Every reason to stop a run early, and the halt.

    `before_tick` (a pre-tick handler) latches the e-stop inputs into `cell.estop`, so the
    perception stage publishes it and guards in the tree see it on the same tick; `check`
    (after each tick) asks each of `checks` in turn. A check is a function returning a `Stop`
    or None: a cell supervisor (arm or gripper faults, stale perception) joins by adding one.
    """

    def __init__(self, cell: Cell, tip: Tip, bridge: DesignBridge | None = None,
                 estop_file: Path | None = None, estop_at: float | None = None,
                 max_time: float = 3600.0):
        self.cell = cell
        self.tip = tip
        self.bridge = bridge
        self.estop_file = estop_file
        self.estop_at = estop_at
        self.max_time = max_time
        self.checks: list[Callable[[], Stop | None]] = [self._estop, self._time_limit]
        self._running = ""  # the tip when this tick began: what an e-stop interrupts

    def before_tick(self, tree: py_trees.trees.BehaviourTree) -> None:
        """Pre-tick handler: raise `cell.estop` when its time has come or the ESTOP file exists."""
        self._running = self.tip.path
        if self.estop_at is not None and self.cell.clock.now() >= self.estop_at:
            self.cell.estop = True
        if self.estop_file is not None and self.estop_file.exists():
            self.cell.estop = True

    def check(self) -> Stop | None:
        """After a tick: the first reason to stop now, if any."""
        for check in self.checks:
            stop = check()
            if stop is not None:
                return stop
        return None

    def _estop(self) -> Stop | None:
        if not self.cell.estop:
            return None
        # An e-stop before the first tick interrupts the node that tick started.
        interrupted = self._running or self.tip.path
        return Stop("ESTOP", f"e-stop requested during {interrupted}", interrupted)

    def _time_limit(self) -> Stop | None:
        if self.cell.clock.now() > self.max_time:
            return Stop("TIMEOUT", f"no result within {self.max_time} s of cell time")
        return None

    @staticmethod
    def interrupted() -> Stop:
        """The stop for Ctrl-C."""
        return Stop("HALTED", "interrupted (Ctrl-C)")

    def halt(self, root: py_trees.behaviour.Behaviour, where: str) -> None:
        """Stop the tree (every running node's `terminate` runs), the arm and the gripper, and
        tell the design bridge the run halted at `where`."""
        root.stop(Status.INVALID)
        self.cell.arm.stop()
        self.cell.gripper.stop()
        if self.bridge:
            self.bridge.event("halted", node=where, estop=self.cell.estop)
