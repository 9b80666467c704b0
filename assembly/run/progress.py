"""Terminal progress of a run: one line each time the tree's tip moves."""

from __future__ import annotations

import sys
from collections.abc import Callable

import py_trees
from py_trees.blackboard import Blackboard

from assembly.run.tip import Tip
from behaviours.skill_kit import keys
from drivers.protocols import Clock


class Progress:
    """Post-tick handler telling `say` the cell time, the element being built and the new tip
    whenever the tip moves."""

    def __init__(self, tip: Tip, clock: Clock, say: Callable[[str], None]):
        self.tip, self.clock, self.say = tip, clock, say
        self._shown = ""

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        if self.tip.path != self._shown:
            self._shown = self.tip.path
            element = Blackboard.storage.get(keys.ELEMENT, {}) or {}
            self.say(f"t={self.clock.now():7.2f}s  {element.get('id', '-'):>4}  {self._shown}")


def stderr_progress(line: str) -> None:
    """Show a progress line on stderr: rewritten in place on a terminal, appended otherwise."""
    if sys.stderr.isatty():
        sys.stderr.write("\r\033[K" + line[:150])
    else:
        sys.stderr.write(line + "\n")
    sys.stderr.flush()


def end_stderr_progress() -> None:
    """Leave the in-place progress line on a terminal, so what follows starts on a line of its own."""
    if sys.stderr.isatty():
        sys.stderr.write("\n")
        sys.stderr.flush()
