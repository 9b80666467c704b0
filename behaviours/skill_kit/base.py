"""The base class of every tactile skill: declared parameters, blackboard keys and cell access.

Rules for skill authors:

- Declare everything. `PARAMS` gives each parameter's type, default, unit, range and meaning;
  `READS` and `WRITES` name every blackboard key the skill reads or writes. The YAML loader checks
  a tree against these before the first tick, `fvtree skills` prints them and `fvtree schema`
  turns them into JSON Schema. The blackboard client refuses an undeclared key.
- Read state from the blackboard, send commands to the cell. The perception stage writes one
  snapshot per tick before the tree ticks: the fingertips (/fv/left, /fv/right) and the arm and
  gripper state (/robot/pose, /robot/wrench, /robot/fault, /robot/moving, /gripper/width,
  /gripper/object, /gripper/fault, /gripper/moving). Read them with `tactile()`, `pose()`,
  `arm_fault()`, `arm_moving()`, `gripper_width()`, `gripper_object()`, `gripper_fault()` and
  `gripper_moving()` (or `read(key)`), never from the devices, so every skill of a tick sees
  the same state even while a driver thread updates it. Commands (`move_linear`,
  `speed_linear`, `stop`, `gripper.move`, `gripper.stop`) go to `self.cell.arm` and
  `self.cell.gripper`; constants (`gripper.max_width`, `gripper.max_speed`,
  `cell.clock.period`) may be read from the cell.
- The snapshot is taken at the start of the tick: a command sent in this tick shows in the
  snapshot of the next one. After commanding a motion, yield before testing whether it is still
  moving (`ProgramSkill.move` and `ProgramSkill.grip` do).
- Stop what you started. A skill that ends by itself (SUCCESS or FAILURE) stops the motion it
  commanded; a skill halted mid-run (RUNNING -> INVALID) has its arm and gripper stopped by
  `Skill.terminate`, so an override must call `super().terminate(new_status)`.
- End within a bound. Every skill ends by itself within a bound it can state (a `max_time`, a
  travel or angle limit, a tick budget, the timeout of each move), or sets
  `RUNS_UNTIL_HALTED = True` when it runs until its parent halts it (`estop_guard`). A skill
  whose `duration` 0 means "until halted" says so in `runs_until_halted(params)`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, ClassVar

import numpy as np
import py_trees
from py_trees.blackboard import Blackboard, Client
from py_trees.common import Access, Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.cell import SkillCell
from perception.state import TactileState

REQUIRED = object()  # sentinel: the parameter has no default
_TOUCH_KEYS = (keys.FV_LEFT, keys.FV_RIGHT)

_TYPES: dict[str, tuple[type[Any], ...]] = {"float": (int, float), "int": (int,), "bool": (bool,), "str": (str,)}


# The ranges of a cell's devices a skill param can be bound to (`Param.device`): the cell's arm and gripper
# refuse (or cap) a command beyond them, so `fvtree validate --cell CELL` checks such params against the cell.
DEVICE_RANGES: dict[str, tuple[str, str]] = {  # name -> (what it bounds, what the cell does beyond it)
    "gripper_force": ("gripper force", "the gripper refuses a stronger grip: a FAULT"),
    "gripper_width": ("gripper opening", "the gripper refuses a wider one: a FAULT"),
    "arm_speed": ("TCP speed", "the arm caps a faster move at it"),
    "arm_angular_speed": ("TCP turn rate", "the arm refuses a faster turn: a FAULT"),
    "arm_force": ("force at the TCP", "the arm stops above it: a FAULT"),
}


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
    device: str = ""  # the device range of DEVICE_RANGES the value must lie in on the cell that runs it

    def __post_init__(self) -> None:
        if self.device and self.device not in DEVICE_RANGES:
            raise ValueError(f"device range {self.device!r} is not one of {', '.join(DEVICE_RANGES)}")

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
            out: Any = [self._float(v) for v in value]
            items = out
        else:
            ok = _TYPES[self.type]
            if isinstance(value, bool) and self.type != "bool" or not isinstance(value, ok):
                raise ValueError(f"expected {self.type}, got {type(value).__name__} {value!r}")
            out = self._float(value) if self.type == "float" else value
            items = [out] if self.type in ("float", "int") else []
        for v in items:
            if self.min is not None and v < self.min:
                raise ValueError(f"{v} is below the minimum {self.min}{self.unit and ' ' + self.unit}")
            if self.max is not None and v > self.max:
                raise ValueError(f"{v} is above the maximum {self.max}{self.unit and ' ' + self.unit}")
        if self.choices is not None and out not in self.choices:
            raise ValueError(f"{out!r} is not one of {', '.join(map(repr, self.choices))}")
        return out

    @staticmethod
    def _float(value: float) -> float:
        """A number as a finite float: NaN, infinity and ints beyond float range are refused."""
        try:
            out = float(value)
        except OverflowError:
            raise ValueError("a number beyond the range of floats (1.8e308)") from None
        if not math.isfinite(out):
            raise ValueError(f"{value} is not a finite number")
        return out


def time_limit(default: float, doc: str = "give up after this long") -> Param:
    """The `max_time` param that bounds a skill which could otherwise wait forever."""
    return Param("float", doc, default, "s", min=0.1)


def gone_share() -> Param:
    """The `gone_share` param of skills that judge whether a held object left the fingers (see
    `behaviours.skill_kit.hand.still_seen`)."""
    return Param("float", "object area under this share of the area seen while held counts as gone "
                 "(a few background pixels of the object's colours stay in view)", 0.25, min=0.0, max=1.0)


class KeyReads:
    """Reads through a blackboard client at the cost of a dict lookup: the name of each key the client
    registered is resolved (namespace, remapping) and its access checked once, here, where the client's
    `get` does both on every read. A key registered later, a nested name, an unregistered key (refused
    with AttributeError) and any read while py_trees records its activity stream go through the client."""

    def __init__(self, client: Client):
        self.client = client
        remappings = client.remappings
        self._names = {key: remappings[key] for key in client.read | client.write | client.exclusive}

    def __getitem__(self, key: str) -> Any:
        """The value of `key`; KeyError when it is unset, as from the client."""
        name = self._stored_name(key)
        return self.client.get(key) if name is None else Blackboard.storage[name]

    def get(self, key: str, default: Any = None) -> Any:
        """The value of `key`, or `default` when it is unset, without raising and catching a KeyError
        for an unset key (for_each_element asks for /task/asbuilt every tick, unset until the first
        placement)."""
        name = self._stored_name(key)
        if name is None:
            try:
                return self.client.get(key)
            except KeyError:
                return default
        return Blackboard.storage.get(name, default)

    def _stored_name(self, key: str) -> str | None:
        """The storage name to read `key` at directly, or None to read it through the client."""
        return None if Blackboard.activity_stream is not None else self._names.get(key)


def require_tick_once(cls: type[Any], tick: Callable, tick_once: Callable) -> None:
    """Refuse a class `cls` that overrides the `tick` it inherited but not its `tick_once`: the runner
    ticks with `tick_once`, so such a class would tick one way under the runner, another with visitors."""
    if cls.tick is not tick and cls.tick_once is tick_once:
        raise TypeError(f"{cls.__name__} overrides tick(): it must override tick_once() the same way")


class Skill(py_trees.behaviour.Behaviour):
    """A py_trees behaviour with declared parameters that acts on the cell.

    Subclasses set NAME, PARAMS, READS and WRITES and implement `initialise` and `update`
    (see the module docstring for the rules they follow).
    """

    NAME: ClassVar[str] = ""
    SUMMARY: ClassVar[str] = ""
    PARAMS: ClassVar[dict[str, Param]] = {}
    READS: ClassVar[tuple[str, ...]] = ()
    OPTIONAL_READS: ClassVar[tuple[str, ...]] = ()  # keys of READS read with a fallback: no writer needed
    WRITES: ClassVar[tuple[str, ...]] = ()
    RUNS_UNTIL_HALTED: ClassVar[bool] = False  # True: never ends by itself, its parent halts it

    cell: SkillCell  # from `setup(cell=...)`: unset until then, and a skill ticks only once set up

    def __init__(self, name: str, resolved: dict[str, Any] | None = None, **params: Any):
        """`params` are checked and completed with defaults; `resolved` params (from the tree
        loader, which has checked them already) are taken as they are."""
        super().__init__(name=name)
        self.p = SimpleNamespace(**(resolved if resolved is not None else self.resolve_params(params)))
        self.bb = self.attach_blackboard_client(name=name)
        for key in self.READS:
            self.bb.register_key(key=key, access=Access.READ)
        for key in self.WRITES:
            self.bb.register_key(key=key, access=Access.WRITE)
        self.reads = KeyReads(self.bb)

    @classmethod
    def resolve_params(cls, given: dict[str, Any]) -> dict[str, Any]:
        """Validate given params against PARAMS and fill defaults; raises KeyError/ValueError."""
        unknown = set(given) - set(cls.PARAMS)
        if unknown:
            raise KeyError(min(unknown))
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

    @classmethod
    def runs_until_halted(cls, params: dict[str, Any]) -> bool:
        """Whether the skill with these (resolved) params runs until halted instead of ending
        by itself; skills whose `duration` 0 means "until halted" override it."""
        return cls.RUNS_UNTIL_HALTED

    def setup(self, **kwargs: Any) -> None:
        cell = kwargs.get("cell")
        if cell is None:
            raise RuntimeError(f"skill {self.name!r} needs tree.setup(cell=...) before ticking")
        self.cell = cell

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A skill that changes how it ticks changes both ways of ticking (the runner uses `tick_once`)."""
        super().__init_subclass__(**kwargs)
        require_tick_once(cls, Skill.tick, Skill.tick_once)

    def tick_once(self) -> None:
        """py_trees' `Behaviour.tick` without its generator (the runner ticks the tree without them,
        `assembly.nodes.composites`) nor its per-tick overhead (a debug message formatted whether or not it
        is printed, a list of every Status to check the one returned): initialise unless running,
        update, stop on a final status."""
        if self.status is not Status.RUNNING:
            self.initialise()
        new_status = self.update()
        if not isinstance(new_status, Status):
            self.logger.error(f"A behaviour returned an invalid status, setting to INVALID [{new_status}][{self.name}]")
            new_status = Status.INVALID
        if new_status is not Status.RUNNING:
            self.stop(new_status)
        self.status = new_status

    def tick(self) -> Iterator[Skill]:
        """py_trees' generator tick (for trees ticked with visitors): `tick_once`, then yield itself."""
        self.tick_once()
        yield self

    def stop(self, new_status: Status) -> None:
        """py_trees' `Behaviour.stop` without formatting its debug message (the estop guard stops on
        every tick): terminate, take the status, make the next tick's generator."""
        self.terminate(new_status)
        self.status = new_status
        self.iterator = self.tick()

    def terminate(self, new_status: Status) -> None:
        """Halted mid-run (RUNNING -> INVALID): stop the arm and the gripper, whatever this
        skill commanded. A skill that had already finished leaves the devices alone, since a
        sibling may be moving them."""
        if new_status == Status.INVALID and self.status == Status.RUNNING and hasattr(self, "cell"):
            self.cell.arm.stop()
            self.cell.gripper.stop()

    # Helpers shared by skills ----------------------------------------------------------
    def now(self) -> float:
        return self.cell.clock.now()

    def read(self, key: str, default: Any = None) -> Any:
        """A blackboard value, or `default` when the key is unset."""
        return self.reads.get(key, default)

    def write(self, key: str, value: Any) -> None:
        self.bb.set(key, value, overwrite=True)

    def tactile(self) -> tuple[TactileState, TactileState]:
        """(left, right) TactileStates of this tick."""
        return self.reads[keys.FV_LEFT], self.reads[keys.FV_RIGHT]

    def fail(self, message: str) -> Status:
        self.feedback_message = message
        self.logger.warning(f"{self.name}: {message}")
        return Status.FAILURE

    # This tick's robot state, from the perception stage's snapshot ------------------------
    def _state(self, key: str) -> Any:
        try:
            return self.reads[key]
        except KeyError:
            raise RuntimeError(f"skill {self.name!r}: {key} is not on the blackboard; tick skills "
                               "through the Runner, whose perception stage writes it") from None

    def pose(self) -> np.ndarray:
        """TCP pose [x, y, z, rx, ry, rz] at the start of the tick (a copy: yours to change)."""
        return np.array(self._state(keys.ROBOT_POSE), dtype=float)

    def arm_fault(self) -> str | None:
        return self._state(keys.ROBOT_FAULT)

    def arm_moving(self) -> bool:
        """A move or twist was in progress at the start of the tick."""
        return bool(self._state(keys.ROBOT_MOVING))

    def held_at_box(self) -> str | None:
        """The workspace box's face where the safety layer stopped this skill's twist, or None."""
        return self.cell.arm.held_at

    def gripper_width(self) -> float:
        return float(self._state(keys.GRIPPER_WIDTH))

    def gripper_object(self) -> bool:
        """The fingers had stopped on an object at the start of the tick."""
        return bool(self._state(keys.GRIPPER_OBJECT))

    def gripper_fault(self) -> str | None:
        return self._state(keys.GRIPPER_FAULT)

    def gripper_moving(self) -> bool:
        return bool(self._state(keys.GRIPPER_MOVING))


def summed_force(left: TactileState, right: TactileState) -> np.ndarray:
    """Force felt by the hand: sum of both fingers' force vectors (pixels)."""
    return left.force + right.force


def magnitude(vector: np.ndarray) -> float:
    """Length of a float vector: np.linalg.norm's value (the same dot product and square root),
    without its argument checks, which cost several times the sum on a 3-vector."""
    return math.sqrt(vector.dot(vector))


class ProgramSkill(Skill):
    """A skill written as a generator: `program()` yields once per tick and returns a Status.

    Multi-phase skills (move, measure, decide) then read top to bottom. Interrupting the skill
    closes the generator and stops the arm and the gripper.
    """

    _touch_keys: ClassVar[tuple[str, ...]] = ()  # the fingertip keys among READS, checked every tick

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Find the fingertip keys among the skill's READS once, not on every tick."""
        super().__init_subclass__(**kwargs)
        cls._touch_keys = tuple(key for key in _TOUCH_KEYS if key in cls.READS)

    def initialise(self) -> None:
        self.feedback_message = ""
        self._program = self.program()

    def program(self):  # pragma: no cover - abstract
        raise NotImplementedError
        yield

    def update(self) -> Status:
        unhealthy = self._unhealthy_touch()
        if unhealthy:  # reached only where the cell lets skills fail (supervision: fail)
            self.cell.arm.stop()
            self.cell.gripper.stop()
            return self.fail(unhealthy)
        try:
            next(self._program)
        except StopIteration as done:
            return done.value if done.value is not None else Status.SUCCESS
        return Status.RUNNING

    def _unhealthy_touch(self) -> str | None:
        """Why this tick's fingertip states cannot be trusted, for a skill that reads them."""
        for key in self._touch_keys:
            state = self.read(key)
            if state is not None and not state.healthy:
                return f"perception on {key} is unhealthy: {state.health_reason or 'no reason given'}"
        return None

    def terminate(self, new_status: Status) -> None:
        program = getattr(self, "_program", None)
        if program is not None:
            program.close()
            self._program = None
        super().terminate(new_status)

    # Steps usable with `yield from` ---------------------------------------------------------
    def move(self, pose, speed: float, timeout: float = 60.0,
             watch: Callable[[], str | None] | None = None):
        """Linear move to `pose`; yields until arrival and returns None, or why it stopped short.

        Needs /robot/fault and /robot/moving in READS. `watch`, called once per tick while the
        arm moves, may return a reason to stop the arm and abort (e.g. slip in the grasp)."""
        arm = self.cell.arm
        arm.move_linear(np.asarray(pose, dtype=float), speed)
        fault = self.arm_fault
        return (yield from self._until_still(
            arm.stop, lambda: fault() and f"arm fault during move: {fault()}", self.arm_moving,
            timeout, f"move did not finish within {timeout:.0f} s", watch))

    def grip(self, width: float, speed: float, force: float, timeout: float = 10.0):
        """Move the fingers to `width`; yields until they stop (at the width or on an object)
        and returns None, or why not. Needs /gripper/fault and /gripper/moving in READS."""
        gripper = self.cell.gripper
        gripper.move(width, speed=speed, force=force)
        fault = self.gripper_fault
        return (yield from self._until_still(
            gripper.stop, lambda: fault() and f"gripper fault: {fault()}", self.gripper_moving,
            timeout, f"the fingers did not stop within {timeout:.0f} s"))

    def _until_still(self, stop: Callable[[], None], fault: Callable[[], str | None],
                     moving: Callable[[], bool], timeout: float, late: str,
                     watch: Callable[[], str | None] | None = None):
        """Yield until a commanded motion ends; None, or the fault, the watch's reason or `late`
        (the last two after `stop`)."""
        deadline = self.now() + timeout
        while True:
            yield  # the snapshot shows the motion from the next tick on
            reason = fault()
            if reason:
                return reason
            reason = watch() if watch is not None else None
            if reason:
                stop()
                return reason
            if not moving():
                return None
            if self.now() > deadline:
                stop()
                return late

    def mean_force(self, ticks: int):
        """Average summed finger force over the next `ticks` ticks."""
        total = np.zeros(3)
        for _ in range(ticks):
            yield
            left, right = self.tactile()
            total += summed_force(left, right)
        return total / ticks
