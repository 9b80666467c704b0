"""Test doubles that stand in for a node of a tree (`assembly.language.substitution` puts them in place): a
status double that answers a scripted status, or another skill with its own params. Both say in
their feedback, and so in the transition log, which node they replace."""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.common import Status

from assembly.language.validator import NodeKind, NodeSpec
from behaviours.skill_kit.base import Skill
from behaviours.skill_kit.registry import SKILLS


class StatusDouble(py_trees.behaviour.Behaviour):
    """RUNNING for `running_ticks` ticks after each start, then `final` (RUNNING: for ever)."""

    def __init__(self, name: str, running_ticks: int, final: Status, note: str):
        super().__init__(name=name)
        self.running_ticks, self.final, self.note = running_ticks, final, note
        self.count = 0

    def initialise(self) -> None:
        self.count = 0

    def update(self) -> Status:
        self.count += 1
        status = Status.RUNNING if self.count <= self.running_ticks else self.final
        self.feedback_message = f"{self.note} (tick {self.count})"
        return status


def marked_skill(cls: type[Skill], note: str) -> type[Skill]:
    """`cls` whose feedback starts with `note`, so every line the double logs says what it replaces."""

    class Substituted(cls):  # type: ignore[misc, valid-type]
        def update(self) -> Status:
            status = super().update()
            self.feedback_message: str = f"{note}: {self.feedback_message}"  # (typed: the base is a variable)
            return status

    Substituted.__name__ = Substituted.__qualname__ = f"Substituted{cls.__name__}"
    return Substituted


def _build_status(spec: NodeSpec, kids: list[Any]) -> py_trees.behaviour.Behaviour:
    a = spec.args
    return StatusDouble(spec.name, a["running_ticks"], Status[a["final"].upper()], a["note"])


def _build_skill(spec: NodeSpec, kids: list[Any]) -> py_trees.behaviour.Behaviour:
    return marked_skill(SKILLS[spec.type], spec.args["note"])(spec.name, resolved=spec.args["params"])


def _not_in_files(*_args: Any) -> None:
    raise AssertionError("test doubles are put in place by assembly.language.substitution, never read from a tree file")


# Kinds `assembly.language.reader.build` knows besides the language's own: never valid in a tree file.
DOUBLE_KINDS: dict[str, NodeKind] = {
    "status_double": NodeKind("a scripted status standing in for a node", {}, frozenset(), _not_in_files,
                              _build_status),
    "skill_double": NodeKind("another skill standing in for a node", {}, frozenset(), _not_in_files, _build_skill),
}
