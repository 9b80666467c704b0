"""Driver-level safety around any Gripper: the gate every finger command passes.

`SafeGripper` refuses (never clamps) a non-finite width, speed or force, a width outside
[0, max_width], a speed at or below zero and a force outside [0, max_force], latching a fault that
names the command and the bad value; a speed above the gripper's `max_speed` is capped. Anything
the driver raises latches a fault instead of escaping, and so does the driver's own fault (e.g. a
Robotiq overcurrent) once seen. `fault()` reports every latched cause; `stop()` is always safe.
"""

from __future__ import annotations

import math

from drivers.guard import Guard, Refused, finite_number, positive_number, truth_value
from drivers.protocols import Gripper

WIDTH_TOLERANCE = 1e-6  # m a width may pass the stroke's ends by (rounding)
MAX_FORCE = 235.0  # N, the strongest grip of the Robotiq 2F-85, for grippers that state none


class SafeGripper(Guard):
    """A Gripper that checks every command and latches every fault of another Gripper."""

    def __init__(self, gripper: Gripper, max_force: float = MAX_FORCE):
        super().__init__(gripper, "gripper")
        self.max_force = positive_number("max_force", max_force)

    @property
    def max_width(self) -> float:
        return self.inner.max_width

    @property
    def max_speed(self) -> float:
        return self.inner.max_speed

    # --- state, checked on the way through ----------------------------------------------------
    def width(self) -> float:
        return self._read("width", self.inner.width, math.nan, finite_number)

    def is_moving(self) -> bool:
        return self._read("is_moving", self.inner.is_moving, False, truth_value)

    def object_detected(self) -> bool:
        return self._read("object_detected", self.inner.object_detected, False, truth_value)

    # --- guarded command ---------------------------------------------------------------------
    def move(self, width: float, speed: float = 0.05, force: float = 20.0) -> None:
        with self._lock:
            if self._refuse("gripper move"):
                return
            checked = self._gate("gripper move", lambda: self._check(width, speed, force))
            if checked is not None:
                self._forward("gripper move", self.inner.move, *checked)

    def _check(self, width: float, speed: float, force: float) -> tuple[float, float, float]:
        w, v, f = finite_number("width", width), positive_number("speed", speed), finite_number("force", force)
        if not -WIDTH_TOLERANCE <= w <= self.max_width + WIDTH_TOLERANCE:
            raise Refused(f"width {w!r} m is outside [0, {self.max_width:g}] m")
        if not 0.0 <= f <= self.max_force:
            raise Refused(f"force {f!r} N is outside [0, {self.max_force:g}] N")
        return min(max(w, 0.0), self.max_width), min(v, self.max_speed), f
