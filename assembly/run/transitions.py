"""The transition log of a run: one JSON line per node status change, stamped like the event log
(tick, cell time `t`, wall time, the element in work) so the two line up; a resumed run's ticks
go on from the last one its earlier sessions logged."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from operator import attrgetter
from pathlib import Path
from typing import TextIO

import py_trees
from py_trees.common import Status

from assembly.language.build import BuiltTree
from behaviours.skill_kit.keys import ELEMENT
from drivers.protocols import Clock

STATUS = attrgetter("status")


def element_in_work() -> str | None:
    """The id of the design element on /task/element (`for_each_element` publishes it), if any."""
    element = py_trees.blackboard.Blackboard.storage.get(ELEMENT)
    return element.get("id") if isinstance(element, dict) else None


def last_tick(path: Path) -> int | None:
    """The tick of a transition log's last whole record (None for none): a resumed run goes on after it."""
    try:
        with open(path, "rb") as f:
            f.seek(0, os.SEEK_END)
            f.seek(max(0, f.tell() - 65536))
            tail = f.read().decode("utf-8", errors="replace")
    except OSError:
        return None
    for line in reversed(tail.splitlines()):
        try:
            tick = json.loads(line).get("tick")
        except (ValueError, AttributeError):
            continue  # a torn last line, or part of one
        if isinstance(tick, int) and not isinstance(tick, bool) and tick >= 0:
            return tick
    return None


class TransitionLog:
    """Post-tick handler writing each node status change as a JSON line (tick, cell time `t`, wall
    time, the element in work, node path, old -> new status, feedback), flushed every tick so a
    crashed run keeps its log. Ticks are the run's: a session resumed on an existing log numbers
    its ticks on from the log's last (`tick_base`).

    A log that cannot be written (a full disk, a file-size limit) stops at its first failed write
    and tells `on_lost(exception, since)`, and the run goes on: the as-built records matter more."""

    def __init__(self, tree: BuiltTree, clock: Clock, path: Path,
                 on_lost: Callable[[OSError, str], None] | None = None):
        self.clock = clock
        self.on_lost = on_lost
        self._nodes = list(tree.nodes.items())
        self._last = {path: Status.INVALID for path, _ in self._nodes}
        self._node_objects = [node for _, node in self._nodes]
        self._seen = [Status.INVALID] * len(self._nodes)  # every node's status at the last record
        self._file: TextIO | None = None
        self._element_before: str | None = None  # the element in work as the tick began
        last = last_tick(path)
        self.tick_base = 0 if last is None else last + 1  # the ticks of earlier sessions of this run come first
        try:
            self._file = open(path, "a")  # noqa: SIM115 - open for the whole run; close() closes it
        except OSError as exc:
            self._lost(exc, "the start")

    def before_tick(self, tree: py_trees.trees.BehaviourTree) -> None:
        """Pre-tick handler: the element in work as the tick begins (see `record`)."""
        self._element_before = element_in_work()

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        self.record(tree.count)

    def record(self, tick: int) -> None:
        """Log the changes since the last record under tick number `tick`."""
        statuses = list(map(STATUS, self._node_objects))
        if statuses == self._seen:  # the usual tick: nothing changed
            return
        self._seen = statuses
        changes = []
        stamp = {"tick": self.tick_base + tick, "t": round(self.clock.now(), 6), "wall": round(time.time(), 3)}
        # A node that ends (or is halted) ends its work on the element of the tick's start; one that
        # starts runs for the element of its end: at the tick for_each_element names the next
        # element, the last one's nodes succeed.
        now = element_in_work()
        before = self._element_before if self._element_before is not None else now
        for path, node in self._nodes:
            status = node.status
            if status is not self._last[path]:
                changes.append({**stamp, "element": now if status is Status.RUNNING else before, "node": path,
                                "from": self._last[path].name, "to": status.name, "feedback": node.feedback_message})
                self._last[path] = status
        if changes and self._file:
            try:
                self._file.write("".join(json.dumps(c) + "\n" for c in changes))
                self._file.flush()
            except OSError as exc:
                self._lost(exc, f"tick {tick}")

    def close(self) -> None:
        """Flush to disk and close; later records are dropped."""
        if self._file:
            try:
                self._file.flush()
                os.fsync(self._file.fileno())
            except OSError as exc:
                self._lost(exc, "its end")
            else:
                self._file.close()
                self._file = None

    def _lost(self, exc: OSError, since: str) -> None:
        """Stop writing (the records buffered are dropped) and tell `on_lost`."""
        file, self._file = self._file, None
        if file is not None:
            try:
                file.close()
            except OSError:  # closing flushes the buffer again, into the same full disk
                pass
        if self.on_lost is not None:
            self.on_lost(exc, since)
