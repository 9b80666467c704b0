"""Every decorator of the YAML language: py_trees' retry, repeat, inverter and pass-through (a
subtree instance), and those the language adds: a timeout on the cell clock, a guard that re-checks
a condition every tick, and status mapping. All but the guard tick without generators under the
runner (`DirectDecorator`, as `assembly.nodes.composites` does for sequences and selectors)."""

from __future__ import annotations

import py_trees
from py_trees.common import Status

from assembly.nodes.conditions import Condition
from behaviours.skill_kit.base import require_tick_once
from drivers.protocols import Clock

RUNNING, INVALID = Status.RUNNING, Status.INVALID


class DirectDecorator(py_trees.decorators.Decorator):
    """Gives a py_trees decorator whose `tick` is `Decorator.tick` a `tick_once` without generators.
    Put it first among the bases; a subclass overriding `tick` overrides `tick_once` too."""

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        require_tick_once(cls, py_trees.decorators.Decorator.tick, DirectDecorator.tick_once)

    def tick_once(self) -> None:
        """py_trees' `Decorator.tick`: initialise unless running, tick the child, update, and
        end the tick with the status `update` returned (`end_tick`)."""
        if self.status is not RUNNING:
            self.initialise()
        self.decorated.tick_once()
        self.end_tick(self.update())

    def end_tick(self, new_status: Status) -> None:
        """The end of py_trees' `Decorator.tick`: a status that is none becomes INVALID (logged as
        an error); a final status stops the decorator (and so its running child); take it."""
        if not isinstance(new_status, Status):
            self.logger.error(f"A behaviour returned an invalid status, setting to INVALID [{new_status}][{self.name}]")
            new_status = INVALID
        if new_status is not RUNNING:
            self.stop(new_status)
        self.status = new_status


class PassThrough(DirectDecorator, py_trees.decorators.PassThrough):
    """py_trees' PassThrough (a subtree instance), ticked without generators."""


class Retry(DirectDecorator, py_trees.decorators.Retry):
    """py_trees' Retry, ticked without generators."""


class Repeat(DirectDecorator, py_trees.decorators.Repeat):
    """py_trees' Repeat, ticked without generators."""


class Inverter(DirectDecorator, py_trees.decorators.Inverter):
    """py_trees' Inverter, ticked without generators."""


class CellTimeout(DirectDecorator, py_trees.decorators.Decorator):
    """FAILURE (child halted) when the child runs longer than `duration` s of cell time.

    py_trees' own Timeout reads time.monotonic(); this one reads the cell clock, so simulated
    runs stay deterministic.
    """

    clock: Clock  # the cell's, from `setup(cell=...)`

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, duration: float):
        super().__init__(name=name, child=child)
        self.duration = duration
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
    """Ticks the child only while a condition holds; halts it and fails the tick it stops, with the
    condition's reason as its feedback (the key, its value and the comparison)."""

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, condition: Condition):
        self.check = condition
        super().__init__(name=name, child=child, condition=self._holds)

    def _holds(self) -> bool:
        ok, reason = self.check.evaluate()
        self.feedback_message = "" if ok else f"guard condition failed: {reason}"
        return ok

    def update(self) -> Status:
        return self.decorated.status


class StatusMap(DirectDecorator, py_trees.decorators.Decorator):
    """Returns the child's status translated through `mapping` (e.g. FAILURE -> SUCCESS)."""

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, mapping: dict[Status, Status]):
        super().__init__(name=name, child=child)
        self.mapping = mapping

    def update(self) -> Status:
        return self.mapping.get(self.decorated.status, self.decorated.status)
