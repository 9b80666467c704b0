"""When a run stops before its tree finishes, and how it stops.

A run stops on an e-stop (the cell's input, an `ESTOP` file in the run directory checked every
tick, or one scheduled at a cell time), when its cell-time limit passes, on Ctrl-C or SIGTERM
(`Terminated`), or on a fault latched by the cell supervisor (`assembly.run.supervisor`, one of
`checks`). Stopping halts the tree: every running skill's `terminate` runs, the arm and the
gripper stop (even when a `terminate` raises) and the run's event log records it. Every stop
message names the node that was running.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import py_trees
from py_trees.common import Status

from assembly.design.bridge import DesignBridge
from assembly.run.events import EventSink
from assembly.run.tip import Tip
from assembly.signals import Terminated
from drivers.cell import Cell

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Stop:
    """Why a run stopped: the result status, its message, and the node to name (None: the tip
    when the tree was halted)."""

    status: str  # ESTOP | TIMEOUT | HALTED | FAULT
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
                 max_time: float = 3600.0, events: EventSink | None = None):
        self.cell = cell
        self.tip = tip
        self.bridge = bridge
        self.events = events if events is not None else bridge  # where the halt is logged
        # Kept as a str: os.access, every tick, takes a Path at twice the cost (~2 us against ~1 us).
        self.estop_file = None if estop_file is None else os.fspath(estop_file)
        self.estop_at = estop_at
        self.max_time = max_time
        self.checks: list[Callable[[], Stop | None]] = [self._estop, self._time_limit]
        if bridge is not None and bridge.links:
            self.checks.append(self._design_link)
        self._running = ""  # the tip when this tick began: what an e-stop interrupts

    def before_tick(self, tree: py_trees.trees.BehaviourTree) -> None:
        """Pre-tick handler: raise `cell.estop` when its time has come or the ESTOP file exists."""
        self._running = self.tip.path
        if self.estop_at is not None and self.cell.clock.now() >= self.estop_at:
            self.cell.estop = True
        if self.estop_file is not None and os.access(self.estop_file, os.F_OK):  # Path.exists raises and
            self.cell.estop = True  # catches an error on every tick the file is not there: 3x the cost

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
            return Stop("TIMEOUT", f"no result within {self.max_time} s of cell time (during {self.tip.path})")
        return None

    def _design_link(self) -> Stop | None:
        """A live design link that must stop the cell (a refused or lost claim, a refused login)."""
        assert self.bridge is not None
        reason = self.bridge.fault()
        return None if reason is None else Stop("FAULT", f"design link: {reason} (during {self.tip.path})")

    def interrupted(self, interrupt: KeyboardInterrupt) -> Stop:
        """The stop for Ctrl-C or SIGTERM."""
        what = "SIGTERM" if isinstance(interrupt, Terminated) else "Ctrl-C"
        return Stop("HALTED", f"interrupted ({what}) during {self.tip.path}")

    def halt(self, root: py_trees.behaviour.Behaviour, where: str, event: str = "halted", **data) -> None:
        """Stop the tree (every running node's `terminate` runs, even after one raised), the arm
        and the gripper, and log `event` (with `data`) at `where` in the run's event log."""
        try:
            for node in list(root.iterate()):  # children before their parents, as `root.stop` does
                if node.status != Status.INVALID:
                    try:
                        node.stop(Status.INVALID)
                    except Exception:  # one raising terminate must not skip the others
                        log.exception("halting %s at %s", node.name, where)
                        node.status = Status.INVALID  # halted all the same: its parents skip it
        finally:
            self.cell.arm.stop()
            self.cell.gripper.stop()
        if self.events is not None:
            self.events.event(event, node=where, estop=self.cell.estop, **data)
