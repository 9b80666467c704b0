"""Driver-level safety, wrapped around any Arm whatever the backend and whatever a skill asks.

`SafeArm` is the gate every arm command passes: it refuses (never clamps) non-finite poses, twists
and speeds, speeds at or below zero, rotation vectors turning beyond pi and wrong shapes, latching a
fault that names the command and the bad value; it clamps (or refuses) targets outside the workspace
box, caps the TCP's linear speed and refuses a turn faster than `max_angular_speed`. A twist is held
inside the box too: when it is commanded and again every control period while it runs, the pose the
arm would reach one period ahead (plus the distance it needs to brake) is checked, and the twist's
components that would cross a face are dropped (or the arm stopped with a fault, `refuse`). Anything the driver raises, in a command or a state
read, latches a fault instead of escaping, and a non-finite pose or force reading stops the arm. It
also stops on excess force, and runs a watchdog that stops the arm when the tree stops ticking
(`kick` not called) or the arm's state goes stale. On real hardware the watchdog also runs in its
own thread (`start_watchdog`), so it fires even when the tick loop itself hangs; `kick` and that
thread feed the controller's own watchdog where the arm has one (the last line of defence if this
process dies), the thread only while the tree ticks, so a slow tick cannot starve the controller's
watchdog and a stalled tree is still stopped. Faults stay latched until `reset` is called by a person (never automatically); `fault()`
reports every latched cause.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from drivers.guard import Guard, finite_number, finite_pose, finite_vector, positive_number, truth_value
from drivers.protocols import Arm, Clock

log = logging.getLogger(__name__)
WORKSPACE_POLICIES = ("clamp", "refuse")
NO_READING = np.full(6, np.nan)  # what a read returns when the driver never gave a good one
CONTROLLER_FEED_PERIOD = 0.02  # s of wall time between feeds of the controller's watchdog by the thread


@runtime_checkable
class ControllerWatchdog(Protocol):
    """An arm whose controller stops it by itself unless it is kicked often enough."""

    def kick_watchdog(self) -> None: ...


@dataclass(frozen=True)
class SafetyLimits:
    """Limits from the cell file. Positions in metres (base frame), speed m/s, angular speed rad/s,
    force N, times s. Every value must be finite; all but the box corners positive."""

    workspace_min: np.ndarray = field(default_factory=lambda: np.array([-1.0, -1.0, 0.0]))
    workspace_max: np.ndarray = field(default_factory=lambda: np.array([1.0, 1.0, 1.0]))
    max_speed: float = 0.25
    max_angular_speed: float = 1.0  # rad/s, the TCP's turn rate in a twist
    max_force: float = 150.0
    watchdog_timeout: float = 0.5  # s without a kick (tree tick) before the arm is stopped
    stale_after: float = 0.1  # s without fresh arm state before the arm is stopped
    out_of_workspace: str = "clamp"  # clamp: pull targets into the box; refuse: stop and fault
    reach: float | None = None  # m from the base origin the TCP can reach (UR5e 0.85, UR10e 1.3); None: the box only

    def __post_init__(self):
        lo, hi = _corner("workspace_min", self.workspace_min), _corner("workspace_max", self.workspace_max)
        if np.any(lo >= hi):
            raise ValueError(f"workspace box must be 3 mins below 3 maxes, got {lo.tolist()} .. {hi.tolist()}")
        for name in ("max_speed", "max_angular_speed", "max_force", "watchdog_timeout", "stale_after"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"safety limit {name} must be a positive number, got {value!r}")
            if value <= 0:
                raise ValueError(f"safety limit {name} must be positive, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.reach is not None:
            if isinstance(self.reach, bool) or not isinstance(self.reach, (int, float)) \
                    or not math.isfinite(self.reach) or self.reach <= 0:
                raise ValueError(f"safety limit reach must be a positive number of metres, got {self.reach!r}")
            object.__setattr__(self, "reach", float(self.reach))
        if self.out_of_workspace not in WORKSPACE_POLICIES:
            raise ValueError(f"out_of_workspace must be one of {WORKSPACE_POLICIES}, "
                             f"got {self.out_of_workspace!r}")
        object.__setattr__(self, "workspace_min", lo)
        object.__setattr__(self, "workspace_max", hi)

    def within(self, position: np.ndarray) -> np.ndarray:
        """`position` pulled into the box and, with a `reach`, onto the sphere of that radius about
        the base origin (then into the box again: the two are convex, the result lies in both when
        they meet)."""
        inside = np.clip(position, self.workspace_min, self.workspace_max)
        if self.reach is not None and float(np.linalg.norm(inside)) > self.reach:
            inside = np.clip(inside * (self.reach / float(np.linalg.norm(inside))), self.workspace_min, self.workspace_max)
        return inside

    def reach_problem(self, position: np.ndarray) -> str | None:
        """Why `position` (m, base frame) is out of the box or the reach, or None."""
        axes = [f"{'xyz'[i]} {position[i]:g} not in [{self.workspace_min[i]:g}, {self.workspace_max[i]:g}]"
                for i in range(3) if not self.workspace_min[i] <= position[i] <= self.workspace_max[i]]
        if axes:
            return ", ".join(axes)
        distance = float(np.linalg.norm(position))
        if self.reach is not None and distance > self.reach:
            return f"{distance:.3f} m from the base, beyond the arm's reach {self.reach:g} m"
        return None

    @classmethod
    def from_dict(cls, d: dict) -> SafetyLimits:
        known = set(cls.__dataclass_fields__)
        unknown = set(d) - known
        if unknown:
            raise ValueError(f"unknown safety limit(s) {sorted(unknown)}; known: {sorted(known)}")
        return cls(**d)


def _corner(name: str, value) -> np.ndarray:
    """A workspace corner as 3 finite floats, or ValueError."""
    try:
        corner = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 numbers [x, y, z], got {value!r}") from None
    if corner.shape != (3,) or not np.all(np.isfinite(corner)):
        raise ValueError(f"{name} must be 3 finite numbers [x, y, z], got {value!r}")
    return corner


class SafeArm(Guard):
    """An Arm that enforces `SafetyLimits` on another Arm."""

    def __init__(self, arm: Arm, limits: SafetyLimits, clock: Clock):
        super().__init__(arm, "arm")
        self.limits = limits
        self.clock = clock
        self._last_kick = clock.now()
        self.clamped = 0  # count of targets pulled back into the workspace (for reports)
        # (requested, reachable) position of the last move_linear target pulled into the box, or None:
        # the skill that asked for it learns it did not get where it asked (skill_kit.base.move)
        self.clamped_target: tuple[np.ndarray, np.ndarray] | None = None
        self._twist: np.ndarray | None = None  # the twist forwarded last, while it is held
        self.held_at: str | None = None  # the box face that stopped the held twist, until the next command
        self._watchdog: threading.Thread | None = None
        self._watchdog_period: float | None = None  # set by start_watchdog
        self._watchdog_stop = threading.Event()
        self._controller_watchdog = isinstance(arm, ControllerWatchdog)  # checked once: it is slow
        # m an arm travels while a twist of the given speed is brought to rest; none: it stops at once
        self._braking: Callable[[float], float] | None = getattr(arm, "braking_distance", None)

    # --- state, checked on the way through ----------------------------------------------------
    def pose(self) -> np.ndarray:
        return self._read("pose", self.inner.pose, NO_READING, finite_vector)

    def tcp_speed(self) -> np.ndarray:
        return self._read("tcp_speed", self.inner.tcp_speed, NO_READING, finite_vector)

    def tcp_wrench(self) -> np.ndarray:
        return self._read("tcp_wrench", self.inner.tcp_wrench, NO_READING, finite_vector)

    def state_stamp(self) -> float:
        return self._read("state_stamp", self.inner.state_stamp, -math.inf, finite_number)

    def is_moving(self) -> bool:
        return self._read("is_moving", self.inner.is_moving, False, truth_value)

    # --- guarded commands -------------------------------------------------------------------
    def move_linear(self, pose: np.ndarray, speed: float) -> None:
        with self._lock:
            self.clamped_target = None
            if self._refuse("move_linear"):
                return
            checked = self._gate("move_linear", lambda: (finite_pose("pose", pose), positive_number("speed", speed)))
            if checked is None:
                return
            goal, speed = checked
            clipped = self.limits.within(goal[:3])
            if not np.allclose(clipped, goal[:3]):  # beyond rounding: refuse, or clamp and count
                if self.limits.out_of_workspace == "refuse":
                    self.trip(f"workspace: target {np.round(goal[:3], 4).tolist()} is outside "
                              f"the box {self.limits.workspace_min.tolist()} .. "
                              f"{self.limits.workspace_max.tolist()}"
                              + (f" or the arm's reach {self.limits.reach:g} m" if self.limits.reach else ""))
                    return
                self.clamped += 1
                self.clamped_target = (goal[:3].copy(), clipped.copy())
                log.warning("target %s outside the workspace, clamped to %s", goal[:3], clipped)
            goal[:3] = clipped
            self._twist, self.held_at = None, None
            self._forward("move_linear", self.inner.move_linear, goal, min(speed, self.limits.max_speed))

    def speed_linear(self, twist: np.ndarray) -> None:
        with self._lock:
            if self._refuse("speed_linear"):
                return
            v = self._gate("speed_linear", lambda: finite_vector("twist", twist))
            if v is None:
                return
            turn = float(np.linalg.norm(v[3:]))
            if turn > self.limits.max_angular_speed:
                self.trip(f"speed_linear refused: angular speed {turn:.4g} rad/s is over the cell's "
                          f"max_angular_speed {self.limits.max_angular_speed:g} rad/s")
                return
            _cap(v[:3], self.limits.max_speed)
            p = self.pose()[:3]
            if self._causes:
                return  # the pose could not be read: the arm is stopped
            self.held_at = None
            self._send_within_box("speed_linear", p, v)

    def workspace(self) -> tuple[np.ndarray, np.ndarray]:
        """The box's lower and upper corners (m, base frame): skills bound their travel by it."""
        return self.limits.workspace_min.copy(), self.limits.workspace_max.copy()

    def _send_within_box(self, what: str, p: np.ndarray, v: np.ndarray) -> None:
        """Forward twist `v` from TCP position `p` without the components that would take the TCP
        through a face of the box before the next check; with `refuse`, such a twist stops the arm
        with a fault instead. The twist sent is kept, to be checked again every control period."""
        crossing = self._crossing(p, v[:3])
        if crossing is not None:
            if self.limits.out_of_workspace == "refuse":
                self.trip(f"workspace: the twist {np.round(v[:3], 4).tolist()} m/s would take the TCP "
                          f"from {np.round(p, 4).tolist()} through the box's {crossing}")
                return
            low, high = self._ahead(p, v[:3])
            v[:3][((v[:3] < 0) & (low < self.limits.workspace_min)) | ((v[:3] > 0) & (high > self.limits.workspace_max))] = 0.0
            self.clamped += 1
            self.held_at = crossing
            log.warning("%s held at the workspace box's %s", what, crossing)
        self._twist = v if np.any(v) else None
        self._forward("speed_linear", self.inner.speed_linear, v)

    def _ahead(self, p: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per axis, the lowest and highest position the TCP may reach before the next check stops
        it: one control period of travel at `v`, plus the braking distance the arm declares."""
        reach = v * self.clock.period
        speed = float(np.linalg.norm(v))
        if self._braking is not None and speed > 0:
            reach = reach + v * (self._braking(speed) / speed)  # the arm brakes along the twist's line
        return p + np.minimum(reach, 0.0), p + np.maximum(reach, 0.0)

    def _crossing(self, p: np.ndarray, v: np.ndarray) -> str | None:
        """The face a twist `v` from `p` would cross before the next check, as text, or None."""
        low, high = self._ahead(p, v)
        for axis, name in enumerate("xyz"):
            if v[axis] < 0 and low[axis] < self.limits.workspace_min[axis]:
                return f"{name} min {self.limits.workspace_min[axis]:g} m"
            if v[axis] > 0 and high[axis] > self.limits.workspace_max[axis]:
                return f"{name} max {self.limits.workspace_max[axis]:g} m"
        return None

    # --- supervision, called once per tick by the cell ---------------------------------------
    def kick(self) -> None:
        """The tree ticked: feed the watchdog, and the controller's own one if the arm has it."""
        self._last_kick = self.clock.now()
        if self._watchdog_period is not None and self._watchdog is None:
            self._start_watchdog_thread(self._watchdog_period)
        if not self._causes and self._controller_watchdog:
            self._forward("kick_watchdog", self.inner.kick_watchdog)

    def _feed_controller(self) -> None:
        """Feed the controller's watchdog from the watchdog thread, so that a slow tick cannot
        starve it, but only while the tree ticks (within `watchdog_timeout`): a stalled tree is
        stopped by `supervise`, and then the controller's watchdog fires too."""
        with self._lock:
            if not self._causes and self.clock.now() - self._last_kick <= self.limits.watchdog_timeout:
                self._forward("kick_watchdog", self.inner.kick_watchdog)

    def start_watchdog(self, period: float = 0.01) -> None:
        """From the first `kick` on (the tree started ticking), also supervise every `period` s
        from a daemon thread, so the arm stops even when the tick loop hangs and nobody calls
        `supervise`. For wall-clock cells only: a simulated clock does not move by itself."""
        self._watchdog_period = period

    def _start_watchdog_thread(self, period: float) -> None:
        self._watchdog_stop.clear()

        def watch() -> None:
            fed = time.monotonic()
            while not self._watchdog_stop.wait(period):
                self.supervise()
                if self._controller_watchdog and time.monotonic() - fed >= CONTROLLER_FEED_PERIOD:
                    fed = time.monotonic()
                    self._feed_controller()

        self._watchdog = threading.Thread(target=watch, name="safety-watchdog", daemon=True)
        self._watchdog.start()

    def stop_watchdog(self) -> None:
        """End the watchdog thread (at cell close)."""
        self._watchdog_period = None
        self._watchdog_stop.set()
        if self._watchdog is not None:
            self._watchdog.join(timeout=1.0)
            self._watchdog = None

    def supervise(self) -> str | None:
        """Check the driver's fault, the readings, force, watchdog and data age; stop and latch
        a fault on any breach. Returns the latched fault text, or None."""
        with self._lock:
            if self._causes:
                return self.fault()
            now = self.clock.now()
            self.fault()  # latches the driver's own fault
            force = math.hypot(*self.tcp_wrench().tolist()[:3])
            pose = self.pose()
            stamp = self.state_stamp()
            if self._causes:
                return self.fault()  # a driver fault, or a reading that was not finite
            if self._twist is not None and self._crossing(pose[:3], self._twist[:3]) is not None:
                self._send_within_box("held twist", pose[:3], self._twist.copy())
                if self._causes:
                    return self.fault()
            if force > self.limits.max_force:
                self.trip(f"force limit: {force:.1f} N > {self.limits.max_force:.1f} N")
            elif now - self._last_kick > self.limits.watchdog_timeout:
                self.trip(f"watchdog: tree has not ticked for {now - self._last_kick:.3f} s")
            elif now - stamp > self.limits.stale_after:
                self.trip(f"stale arm state: {now - stamp:.3f} s old")
            return self.fault() if self._causes else None  # no trip: the driver's fault was read above

    def _halt(self) -> None:
        self._twist = None
        super()._halt()

    def reset(self) -> None:
        """Clear the latched faults; for a person who has checked the cell, never automatic."""
        with self._lock:
            super().reset()
            self._last_kick = self.clock.now()


def _cap(v: np.ndarray, limit: float) -> None:
    """Scale `v` in place down to norm `limit`, keeping its direction."""
    scale = float(np.abs(v).max())
    norm = scale * float(np.linalg.norm(v / scale)) if scale > 0 else 0.0  # no overflow for huge entries
    if norm > limit:
        v *= limit / norm
