"""Declarative conditions on blackboard values: `key op value`, no eval.

A key is a blackboard key optionally followed by attributes and indices, e.g.
`/fv/left.slip`, `/fv/right.obj.area`, `/fv/left.force[1]`, `/robot/pose[2]`.
"""

from __future__ import annotations

import operator
import re
import reprlib
from collections.abc import Callable
from typing import Any

import py_trees
from py_trees.common import Status

OPS: dict[str, Callable[[Any, Any], bool]] = {
    "eq": operator.eq, "ne": operator.ne, "lt": operator.lt,
    "le": operator.le, "gt": operator.gt, "ge": operator.ge,
}
ALL_OPS = tuple(OPS) + ("exists",)

_PART = re.compile(r"\.([A-Za-z_]\w*)|\[(-?\d+)\]")


def split_key(expr: str) -> tuple[str, list[str | int]]:
    """('/fv/left', ['obj', 'area']) from '/fv/left.obj.area'; ValueError if malformed."""
    m = re.match(r"(/[\w/]+)", expr)
    if not m:
        raise ValueError(f"a condition key starts with '/', got {expr!r}")
    key, rest, parts = m.group(1), expr[m.end():], []
    while rest:
        p = _PART.match(rest)
        if not p:
            raise ValueError(f"cannot read {rest!r} in key {expr!r}; use .attribute or [index]")
        parts.append(p.group(1) if p.group(1) is not None else int(p.group(2)))
        rest = rest[p.end():]
    return key, parts


def resolve(value: Any, parts: list[str | int]) -> Any:
    for part in parts:
        value = value[part] if isinstance(part, int) or isinstance(value, dict) else getattr(value, part)
    return value


class Condition(py_trees.behaviour.Behaviour):
    """SUCCESS when `key op value` holds this tick, FAILURE otherwise (never RUNNING)."""

    def __init__(self, name: str, key: str, op: str, value: Any = None):
        super().__init__(name=name)
        self.key, self.parts = split_key(key)
        self.expr, self.op, self.value = key, op, value
        self.bb = self.attach_blackboard_client(name=name)
        self.bb.register_key(key=self.key, access=py_trees.common.Access.READ)

    def holds(self) -> bool:
        return self.evaluate()[0]

    def evaluate(self) -> tuple[bool, str]:
        """(whether `key op value` holds this tick, why: the key, the value read and the comparison),
        e.g. (False, "/fv/left.slip = 0.31, not lt 0.2")."""
        try:
            current = resolve(self.bb.get(self.key), self.parts)
        except KeyError:
            return False, f"{self.expr}: {self.key} is not on the blackboard"
        except (AttributeError, IndexError, TypeError) as exc:
            return False, f"{self.expr}: cannot be read ({type(exc).__name__}: {exc})"
        if self.op == "exists":
            ok = current is not None
            return ok, f"{self.expr} = {_short(current)}" + ("" if ok else ", not set")
        try:
            ok = bool(OPS[self.op](current, self.value))
        except (TypeError, ValueError) as exc:  # ValueError: an array's truth, e.g. force lt 3
            return False, f"{self.expr} = {_short(current)} cannot be compared: {self.op} {self.value!r} ({exc})"
        return ok, f"{self.expr} = {_short(current)}, {'' if ok else 'not '}{self.op} {self.value!r}"

    def update(self) -> Status:
        ok, self.feedback_message = self.evaluate()
        return Status.SUCCESS if ok else Status.FAILURE


def _short(value: Any) -> str:
    """A value read from the blackboard, cut short enough for a log line (floats to 6 decimals)."""
    if isinstance(value, float):
        return repr(round(float(value), 6))
    return _SHORT.repr(value)


_SHORT = reprlib.Repr()
_SHORT.maxstring = _SHORT.maxother = 60
