"""The transition log of a run: one JSON line per node status change."""

from __future__ import annotations

import json
import os
from operator import attrgetter
from pathlib import Path
from typing import TextIO

import py_trees
from py_trees.common import Status

from assembly.language.build import BuiltTree
from drivers.protocols import Clock

STATUS = attrgetter("status")


class TransitionLog:
    """Post-tick handler writing each node status change as a JSON line (tick, cell time, node
    path, old -> new status, feedback), flushed every tick so a crashed run keeps its log."""

    def __init__(self, tree: BuiltTree, clock: Clock, path: Path):
        self.clock = clock
        self._nodes = list(tree.nodes.items())
        self._last = {path: Status.INVALID for path, _ in self._nodes}
        self._node_objects = [node for _, node in self._nodes]
        self._seen = [Status.INVALID] * len(self._nodes)  # every node's status at the last record
        self._file: TextIO | None = open(path, "a")  # noqa: SIM115 - open for the whole run; close() closes it

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        self.record(tree.count)

    def record(self, tick: int) -> None:
        """Log the changes since the last record under tick number `tick`."""
        statuses = list(map(STATUS, self._node_objects))
        if statuses == self._seen:  # the usual tick: nothing changed
            return
        self._seen = statuses
        changes = []
        for path, node in self._nodes:
            status = node.status
            if status is not self._last[path]:
                changes.append({"tick": tick, "t": round(self.clock.now(), 6), "node": path,
                                "from": self._last[path].name, "to": status.name,
                                "feedback": node.feedback_message})
                self._last[path] = status
        if changes and self._file:
            self._file.write("".join(json.dumps(c) + "\n" for c in changes))
            self._file.flush()

    def close(self) -> None:
        """Flush to disk and close; later records are dropped."""
        if self._file:
            self._file.flush()
            os.fsync(self._file.fileno())
            self._file.close()
            self._file = None
