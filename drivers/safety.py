"""Driver-level safety, wrapped around any Arm whatever the backend and whatever a skill asks.

`SafeArm` clamps (or refuses) targets outside the workspace box, caps TCP speed, stops on excess
force or any driver fault, and runs a watchdog that stops the arm when the tree stops ticking
(`kick` not called) or the arm's state goes stale. On real hardware the watchdog also runs in its
own thread (`start_watchdog`), so it fires even when the tick loop itself hangs, and `kick` feeds
the controller's own watchdog where the arm has one (the last line of defence if this process
dies). A tripped SafeArm stays faulted until `reset` is called by a person (never automatically).
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from drivers.protocols import Arm, Clock, DriverFault

log = logging.getLogger(__name__)
WORKSPACE_POLICIES = ("clamp", "refuse")


@runtime_checkable
class ControllerWatchdog(Protocol):
    """An arm whose controller stops it by itself unless it is kicked often enough."""

    def kick_watchdog(self) -> None: ...


@dataclass(frozen=True)
class SafetyLimits:
    """Limits from the cell file. Positions in metres (base frame), speed m/s, force N."""

    workspace_min: np.ndarray = field(default_factory=lambda: np.array([-1.0, -1.0, 0.0]))
    workspace_max: np.ndarray = field(default_factory=lambda: np.array([1.0, 1.0, 1.0]))
    max_speed: float = 0.25
    max_force: float = 150.0
    watchdog_timeout: float = 0.5  # s without a kick (tree tick) before the arm is stopped
    stale_after: float = 0.1  # s without fresh arm state before the arm is stopped
    out_of_workspace: str = "clamp"  # clamp: pull targets into the box; refuse: stop and fault

    def __post_init__(self):
        lo = np.asarray(self.workspace_min, float)
        hi = np.asarray(self.workspace_max, float)
        if lo.shape != (3,) or hi.shape != (3,) or np.any(lo >= hi):
            raise ValueError(f"workspace box must be 3 mins below 3 maxes, got {lo} .. {hi}")
        for name in ("max_speed", "max_force", "watchdog_timeout", "stale_after"):
            if getattr(self, name) <= 0:
                raise ValueError(f"safety limit {name} must be positive")
        if self.out_of_workspace not in WORKSPACE_POLICIES:
            raise ValueError(f"out_of_workspace must be one of {WORKSPACE_POLICIES}, "
                             f"got {self.out_of_workspace!r}")
        object.__setattr__(self, "workspace_min", lo)
        object.__setattr__(self, "workspace_max", hi)

    @classmethod
    def from_dict(cls, d: dict) -> "SafetyLimits":
        known = set(cls.__dataclass_fields__)
        unknown = set(d) - known
        if unknown:
            raise ValueError(f"unknown safety limit(s) {sorted(unknown)}; known: {sorted(known)}")
        return cls(**d)


class SafeArm:
    """An Arm that enforces `SafetyLimits` on another Arm."""

    def __init__(self, arm: Arm, limits: SafetyLimits, clock: Clock):
        self.inner = arm
        self.limits = limits
        self.clock = clock
        self._fault: str | None = None
        self._last_kick = clock.now()
        self.clamped = 0  # count of targets pulled back into the workspace (for reports)
        self._lock = threading.RLock()  # the tick thread and the watchdog thread both supervise
        self._watchdog: threading.Thread | None = None
        self._watchdog_period: float | None = None  # set by start_watchdog
        self._watchdog_stop = threading.Event()
        self._controller_watchdog = isinstance(arm, ControllerWatchdog)  # checked once: it is slow

    # --- state passes through -------------------------------------------------------------
    def pose(self) -> np.ndarray:
        return self.inner.pose()

    def tcp_speed(self) -> np.ndarray:
        return self.inner.tcp_speed()

    def tcp_wrench(self) -> np.ndarray:
        return self.inner.tcp_wrench()

    def state_stamp(self) -> float:
        return self.inner.state_stamp()

    def is_moving(self) -> bool:
        return self.inner.is_moving()

    def fault(self) -> str | None:
        return self._fault or self.inner.fault()

    # --- guarded commands -------------------------------------------------------------------
    def move_linear(self, pose: np.ndarray, speed: float) -> None:
        with self._lock:
            if self._refuse("move_linear"):
                return
            target = np.array(pose, dtype=float)
            clipped = np.clip(target[:3], self.limits.workspace_min, self.limits.workspace_max)
            if not np.allclose(clipped, target[:3]):
                if self.limits.out_of_workspace == "refuse":
                    self.trip(f"workspace: target {np.round(target[:3], 4).tolist()} is outside "
                              f"the box {self.limits.workspace_min.tolist()} .. "
                              f"{self.limits.workspace_max.tolist()}")
                    return
                self.clamped += 1
                log.warning("target %s outside the workspace, clamped to %s", target[:3], clipped)
                target[:3] = clipped
            self._forward("move_linear", self.inner.move_linear, target,
                          min(float(speed), self.limits.max_speed))

    def speed_linear(self, twist: np.ndarray) -> None:
        with self._lock:
            self._speed_linear(twist)

    def _speed_linear(self, twist: np.ndarray) -> None:
        if self._refuse("speed_linear"):
            return
        v = np.array(twist, dtype=float)
        norm = float(np.linalg.norm(v[:3]))
        if norm > self.limits.max_speed:
            v[:3] *= self.limits.max_speed / norm
        # Never drive further out through a face of the workspace box.
        p = self.inner.pose()[:3]
        out_low = (p <= self.limits.workspace_min) & (v[:3] < 0)
        out_high = (p >= self.limits.workspace_max) & (v[:3] > 0)
        v[:3][out_low | out_high] = 0.0
        self._forward("speed_linear", self.inner.speed_linear, v)

    def stop(self) -> None:
        with self._lock:
            self.inner.stop()

    # --- supervision, called once per tick by the cell ---------------------------------------
    def kick(self) -> None:
        """The tree ticked: feed the watchdog, and the controller's own one if the arm has it."""
        self._last_kick = self.clock.now()
        if self._watchdog_period is not None and self._watchdog is None:
            self._start_watchdog_thread(self._watchdog_period)
        if not self._fault and self._controller_watchdog:
            self.inner.kick_watchdog()

    def start_watchdog(self, period: float = 0.01) -> None:
        """From the first `kick` on (the tree started ticking), also supervise every `period` s
        from a daemon thread, so the arm stops even when the tick loop hangs and nobody calls
        `supervise`. For wall-clock cells only: a simulated clock does not move by itself."""
        self._watchdog_period = period

    def _start_watchdog_thread(self, period: float) -> None:
        self._watchdog_stop.clear()

        def watch() -> None:
            while not self._watchdog_stop.wait(period):
                self.supervise()

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
        """Check force, faults, watchdog and data age; stop and latch a fault on any breach."""
        with self._lock:
            return self._supervise()

    def _supervise(self) -> str | None:
        if self._fault:
            return self._fault
        now = self.clock.now()
        reason = None
        force = float(np.linalg.norm(self.inner.tcp_wrench()[:3]))
        if self.inner.fault():
            reason = f"driver fault: {self.inner.fault()}"
        elif force > self.limits.max_force:
            reason = f"force limit: {force:.1f} N > {self.limits.max_force:.1f} N"
        elif now - self._last_kick > self.limits.watchdog_timeout:
            reason = f"watchdog: tree has not ticked for {now - self._last_kick:.3f} s"
        elif now - self.inner.state_stamp() > self.limits.stale_after:
            reason = f"stale arm state: {now - self.inner.state_stamp():.3f} s old"
        if reason:
            self.trip(reason)
        return self._fault

    def trip(self, reason: str) -> None:
        """Stop the arm and latch `reason` as the fault."""
        with self._lock:
            self._fault = reason  # first: no command may slip in while the arm stops
            log.error("safety stop: %s", reason)
            self.inner.stop()

    def reset(self) -> None:
        """Clear a latched fault; for a person who has checked the cell, never automatic."""
        with self._lock:
            self._fault = None
            self._last_kick = self.clock.now()

    def _forward(self, what: str, command, *args) -> None:
        """Pass a command on; a driver that raises DriverFault trips the safety stop instead of
        crashing the tick."""
        try:
            command(*args)
        except DriverFault as exc:
            self.trip(f"driver fault during {what}: {exc}")

    def _refuse(self, what: str) -> bool:
        if self._fault:
            log.warning("%s refused: arm is stopped (%s)", what, self._fault)
            return True
        return False
