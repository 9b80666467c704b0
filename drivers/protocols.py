"""The small protocols every backend implements: Arm, Gripper, Camera, Clock, and for simulated
cells the World around them, what a world needs of the arm and gripper it acts on (SceneArm,
SceneGripper), and the perception source that reads it.

Skills and the runner talk only to these. Poses are UR-style 6-vectors [x, y, z, rx, ry, rz]
(metres, rotation vector, base frame); widths are metres between the fingertips. Commands are
asynchronous: they start a motion and return, and the caller polls state every tick.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from fvfiles.errors import FvtreeError


class DriverFault(FvtreeError, RuntimeError):
    """A device reported a fault or stopped answering; the tree must fail safe."""

    exit_code = 1  # a device problem, not bad input


@runtime_checkable
class Clock(Protocol):
    def now(self) -> float:
        """Seconds on the cell's clock (simulated or monotonic)."""


@runtime_checkable
class Arm(Protocol):
    def pose(self) -> np.ndarray:
        """Actual TCP pose [x, y, z, rx, ry, rz]."""

    def tcp_speed(self) -> np.ndarray:
        """Actual TCP twist [vx, vy, vz, wx, wy, wz] in m/s and rad/s."""

    def tcp_wrench(self) -> np.ndarray:
        """Measured TCP force and torque (N, N m); zeros where the arm has no sensor."""

    def state_stamp(self) -> float:
        """Cell-clock time of the newest state received from the arm (for stale-data checks)."""

    def move_linear(self, pose: np.ndarray, speed: float) -> None:
        """Start a linear move to `pose` at `speed` m/s; returns at once."""

    def speed_linear(self, twist: np.ndarray) -> None:
        """Command a TCP twist, held until the next command or `stop`."""

    def is_moving(self) -> bool:
        """True while a commanded move or twist is still in progress."""

    def stop(self) -> None:
        """Decelerate to standstill and drop any pending command."""

    def fault(self) -> str | None:
        """Text of the active fault (protective stop, lost link, limit), or None."""


@runtime_checkable
class Gripper(Protocol):
    max_width: float  # m, fully open
    max_speed: float  # m/s, fastest finger motion

    def width(self) -> float:
        """Current opening between the fingertips in metres."""

    def move(self, width: float, speed: float = 0.05, force: float = 20.0) -> None:
        """Start moving the fingers to `width` (m) at `speed` (m/s) with grip `force` (N)."""

    def is_moving(self) -> bool: ...

    def object_detected(self) -> bool:
        """True when the fingers stopped on an object before reaching the requested width."""

    def stop(self) -> None: ...

    def fault(self) -> str | None: ...


@runtime_checkable
class Camera(Protocol):
    def read(self) -> tuple[np.ndarray, float] | None:
        """The next BGR frame and its cell-clock stamp, or None when no frame is available."""

    def close(self) -> None: ...


class PerceptionSource(Protocol):
    """The cell's perception stage: one TactileState per finger for this tick."""

    def __call__(self) -> Mapping[str, Any]: ...


@runtime_checkable
class SceneArm(Protocol):
    """What a simulated world needs of the arm it acts on: the simulated arm, which the world
    integrates, or an emulated arm it only follows."""

    external_wrench: np.ndarray  # force and torque the world puts on the TCP (N, N m), base frame

    def pose(self) -> np.ndarray:
        """Actual TCP pose [x, y, z, rx, ry, rz]."""

    def tcp_speed(self) -> np.ndarray:
        """Actual TCP twist [vx, vy, vz, wx, wy, wz]."""

    def step(self, dt: float) -> None:
        """Integrate the commanded motion over `dt` seconds (nothing where a controller does)."""


@runtime_checkable
class SceneGripper(Protocol):
    """What a simulated world needs of the gripper whose fingertips touch it."""

    object_width: float | None  # m, width of what is between the fingers (None: nothing), set by the world

    def width(self) -> float:
        """Current opening between the fingertips in metres."""

    def squeeze_force(self) -> float:
        """Normal force (N) the pads press the object between them with; 0 without contact."""

    def step(self, dt: float) -> None:
        """Integrate the finger motion over `dt` seconds (nothing where a controller does)."""


@runtime_checkable
class World(Protocol):
    """A simulated scene around the arm and gripper (on an emulated cell, the shadow that follows
    them): it integrates one tick, says what the fingertips touch, and knows the truth a real cell
    cannot sense, for run reports only."""

    def step(self, dt: float) -> None:
        """Advance the scene by `dt` seconds of cell time."""

    def contacts(self) -> Mapping[str, Any]:
        """Per finger, the contact the FingerVision sensor model turns into a TactileState."""

    def metrics(self) -> dict[str, Any]:
        """Scene measures of how the task went (tracking error, angle reached, ...): numbers,
        flags and short texts for the run summary."""

    def truth(self) -> dict[str, dict]:
        """Ground truth per task object (e.g. per placed element: position against the true
        best one, load, regret) for the run report; empty where the scene has none."""

    TOLERANCES: ClassVar[Mapping[str, float]]  # the tolerances `shortfalls` knows, with their defaults

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """From the truth, each way the task was not done (an object dropped, an element placed
        with more regret than `tolerances` allows ...), in words for the run summary."""

    def labels(self) -> dict[str, Any]:
        """This tick's training labels for `fvtree record` (e.g. what a scale reads)."""

    def label_info(self) -> dict[str, dict]:
        """What each label is (e.g. the scale's noise), stored with a recording."""

    def stand(self, element_id: str, pose) -> None:
        """Stand an element already placed, where the as-built model says (a resumed run)."""
