"""Decorators the YAML language adds to py_trees: a timeout on the cell clock, a guard that
re-checks a condition every tick, and status mapping. The timeout and the status map tick without
generators under the runner (`assembly.composites`)."""

from __future__ import annotations

import py_trees
from py_trees.common import Status

from assembly.composites import DirectDecorator
from assembly.conditions import Condition


class CellTimeout(DirectDecorator, py_trees.decorators.Decorator):
    """FAILURE (child halted) when the child runs longer than `duration` s of cell time.

    py_trees' own Timeout reads time.monotonic(); this one reads the cell clock, so simulated
    runs stay deterministic.
    """

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, duration: float):
        super().__init__(name=name, child=child)
        self.duration = duration
        self.clock = None
        self.deadline = 0.0

    def setup(self, **kwargs) -> None:
        self.clock = kwargs["cell"].clock

    def initialise(self) -> None:
        self.deadline = self.clock.now() + self.duration

    def update(self) -> Status:
        if self.decorated.status == Status.RUNNING and self.clock.now() >= self.deadline:
            self.decorated.stop(Status.INVALID)
            self.feedback_message = f"timed out after {self.duration} s"
            return Status.FAILURE
        return self.decorated.status


class Guard(py_trees.decorators.EternalGuard):
    """Ticks the child only while a condition holds; halts it and fails the tick it stops."""

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, condition: Condition):
        super().__init__(name=name, child=child, condition=condition.holds)

    def update(self) -> Status:
        return self.decorated.status


class StatusMap(DirectDecorator, py_trees.decorators.Decorator):
    """Returns the child's status translated through `mapping` (e.g. FAILURE -> SUCCESS)."""

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, mapping: dict[Status, Status]):
        super().__init__(name=name, child=child)
        self.mapping = mapping

    def update(self) -> Status:
        return self.mapping.get(self.decorated.status, self.decorated.status)
