"""The base class of every tactile skill: declared parameters, blackboard keys and cell access.

A skill declares `PARAMS` (type, default, unit, description, range), `READS` and `WRITES`
(blackboard keys). The YAML loader validates a tree against these declarations before the first
tick, `fvtree skills` prints them and `fvtree schema` turns them into JSON Schema.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, ClassVar

import numpy as np
import py_trees
from py_trees.common import Access, Status

REQUIRED = object()  # sentinel: the parameter has no default

_TYPES = {"float": (int, float), "int": (int,), "bool": (bool,), "str": (str,)}


@dataclass(frozen=True)
class Param:
    """Declaration of one skill parameter."""

    type: str  # float | int | bool | str | vector
    doc: str
    default: Any = REQUIRED
    unit: str = ""
    min: float | None = None
    max: float | None = None
    choices: tuple | None = None
    length: int | None = None  # for vectors: number of floats

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def check(self, value: Any) -> Any:
        """Return the value converted to its declared type, or raise ValueError saying why."""
        if value is None and self.default is None:
            return None  # an optional param left unset
        if self.type == "vector":
            if not isinstance(value, (list, tuple)) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
            ):
                raise ValueError(f"expected a list of numbers, got {value!r}")
            if self.length is not None and len(value) != self.length:
                raise ValueError(f"expected {self.length} numbers, got {len(value)}")
            out = [float(v) for v in value]
            items = out
        else:
            ok = _TYPES[self.type]
            if isinstance(value, bool) and self.type != "bool" or not isinstance(value, ok):
                raise ValueError(f"expected {self.type}, got {type(value).__name__} {value!r}")
            out = float(value) if self.type == "float" else value
            items = [out] if self.type in ("float", "int") else []
        for v in items:
            if self.min is not None and v < self.min:
                raise ValueError(f"{v} is below the minimum {self.min}{self.unit and ' ' + self.unit}")
            if self.max is not None and v > self.max:
                raise ValueError(f"{v} is above the maximum {self.max}{self.unit and ' ' + self.unit}")
        if self.choices is not None and out not in self.choices:
            raise ValueError(f"{out!r} is not one of {', '.join(map(repr, self.choices))}")
        return out


class Skill(py_trees.behaviour.Behaviour):
    """A py_trees behaviour with declared parameters that acts on the cell.

    Subclasses set NAME, PARAMS, READS and WRITES, and implement `initialise`, `update` and
    `terminate`; `terminate` must leave the robot safe (stop motion) when interrupted.
    """

    NAME: ClassVar[str] = ""
    SUMMARY: ClassVar[str] = ""
    PARAMS: ClassVar[dict[str, Param]] = {}
    READS: ClassVar[tuple[str, ...]] = ()
    WRITES: ClassVar[tuple[str, ...]] = ()

    def __init__(self, name: str, resolved: dict[str, Any] | None = None, **params: Any):
        """`params` are checked and completed with defaults; `resolved` params (from the tree
        loader, which has checked them already) are taken as they are."""
        super().__init__(name=name)
        self.p = SimpleNamespace(**(resolved if resolved is not None else self.resolve_params(params)))
        self.cell = None
        self.bb = self.attach_blackboard_client(name=name)
        for key in self.READS:
            self.bb.register_key(key=key, access=Access.READ)
        for key in self.WRITES:
            self.bb.register_key(key=key, access=Access.WRITE)

    @classmethod
    def resolve_params(cls, given: dict[str, Any]) -> dict[str, Any]:
        """Validate given params against PARAMS and fill defaults; raises KeyError/ValueError."""
        unknown = set(given) - set(cls.PARAMS)
        if unknown:
            raise KeyError(sorted(unknown)[0])
        out = {}
        for key, decl in cls.PARAMS.items():
            if key in given:
                try:
                    out[key] = decl.check(given[key])
                except ValueError as exc:
                    raise ValueError(f"param {key!r}: {exc}") from None
            elif decl.required:
                raise ValueError(f"missing required param {key!r} ({decl.doc})")
            else:
                out[key] = decl.default
        cls.validate(out)
        return out

    @classmethod
    def validate(cls, params: dict[str, Any]) -> None:
        """Cross-parameter checks; raise ValueError with an actionable message."""

    def setup(self, **kwargs: Any) -> None:
        cell = kwargs.get("cell")
        if cell is None:
            raise RuntimeError(f"skill {self.name!r} needs tree.setup(cell=...) before ticking")
        self.cell = cell

    # Helpers shared by skills ----------------------------------------------------------
    def now(self) -> float:
        return self.cell.clock.now()

    def read(self, key: str, default: Any = None) -> Any:
        """A blackboard value, or `default` when the key is unset."""
        try:
            return self.bb.get(key)
        except KeyError:
            return default

    def write(self, key: str, value: Any) -> None:
        self.bb.set(key, value, overwrite=True)

    def tactile(self):
        """(left, right) TactileStates of this tick."""
        return self.bb.get("/fv/left"), self.bb.get("/fv/right")

    def fail(self, message: str) -> Status:
        self.feedback_message = message
        self.logger.warning(f"{self.name}: {message}")
        return Status.FAILURE

    def stop_arm_if_interrupted(self, new_status: Status) -> None:
        """Stop any motion this skill started when it is halted from outside."""
        if new_status == Status.INVALID and self.cell is not None:
            self.cell.arm.stop()


def summed_force(left, right) -> np.ndarray:
    """Force felt by the hand: sum of both fingers' force vectors (pixels)."""
    return left.force + right.force


class ProgramSkill(Skill):
    """A skill written as a generator: `program()` yields once per tick and returns a Status.

    Multi-phase skills (move, measure, decide) then read top to bottom. Interrupting the skill
    closes the generator and stops the arm.
    """

    def initialise(self) -> None:
        self.feedback_message = ""
        self._program = self.program()

    def program(self):  # pragma: no cover - abstract
        raise NotImplementedError
        yield

    def update(self) -> Status:
        try:
            next(self._program)
        except StopIteration as done:
            return done.value if done.value is not None else Status.SUCCESS
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        program = getattr(self, "_program", None)
        if program is not None:
            program.close()
            self._program = None
        self.stop_arm_if_interrupted(new_status)

    # Steps usable with `yield from` ---------------------------------------------------------
    def move(self, pose, speed: float, timeout: float = 60.0):
        """Linear move to `pose`; yields until arrival. Returns None, or a fault text."""
        arm = self.cell.arm
        arm.move_linear(np.asarray(pose, dtype=float), speed)
        deadline = self.now() + timeout
        while True:
            yield
            if arm.fault():
                return f"arm fault during move: {arm.fault()}"
            if not arm.is_moving():
                return None
            if self.now() > deadline:
                arm.stop()
                return f"move did not finish within {timeout:.0f} s"

    def mean_force(self, ticks: int):
        """Average summed finger force over the next `ticks` ticks."""
        total = np.zeros(3)
        for _ in range(ticks):
            yield
            left, right = self.tactile()
            total += summed_force(left, right)
        return total / ticks
