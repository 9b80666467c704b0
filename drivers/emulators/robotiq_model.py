"""The Robotiq 2F-85/140 register behaviour (manual section 4): activation, position requests with
motion over time, object detection, status bytes and faults. Pure state machine, no I/O; motion is
integrated lazily from the monotonic clock whenever a register is read or written; emulated time
may run `time_scale` times faster than the wall clock."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

# action request byte (register 0, high byte)
rACT, rGTO, rATR = 0x01, 0x08, 0x10
# gSTA values and gOBJ values
STA_RESET, STA_ACTIVATING, STA_ACTIVE = 0, 1, 3
OBJ_MOVING, OBJ_CONTACT_OPENING, OBJ_CONTACT_CLOSING, OBJ_AT_REQUEST = 0, 1, 2, 3
MAJOR_FAULTS = range(0x0A, 0x10)


@dataclass
class GripperSpec:
    """Mechanics of the emulated gripper: stroke, speed and force ranges, activation time, and
    the object between the fingers."""

    stroke: float = 0.085  # m, opening at position 0
    min_speed: float = 0.020  # m/s at rSP = 0
    max_speed: float = 0.150  # m/s at rSP = 255
    activation_time: float = 0.3  # s from the rACT rising edge to gSTA = 3
    min_force: float = 20.0  # N at rFR = 0
    max_force: float = 235.0  # N at rFR = 255
    object_width: float | None = None  # m; the fingers stop on an object this wide when closing
    pad_stiffness: float | None = None  # N/m of the two soft fingertip pads; None: rigid fingers
    time_scale: float = 1.0  # emulated seconds per wall-clock second


class RobotiqModel:
    """Three command registers in, three status registers out."""

    def __init__(self, spec: GripperSpec):
        self.spec = spec
        self.lock = threading.Lock()
        self.action = 0  # last action request byte
        self.request = 0  # rPR
        self.speed = 0  # rSP
        self.force = 0  # rFR
        self.status = STA_RESET
        self.obj = OBJ_MOVING
        self.fault = 0
        self.position = 0.0  # gPO as a float count
        self._activation_started: float | None = None
        self._moving = False
        self._t = self._now()

    def _now(self) -> float:
        return time.monotonic() * self.spec.time_scale

    def write(self, regs: list[int]) -> None:
        """A write to the three command registers (rACT/rGTO..., rPR, rSP/rFR)."""
        with self.lock:
            self._advance()
            action = (regs[0] >> 8) & 0xFF
            self.request, self.speed, self.force = regs[1] & 0xFF, (regs[2] >> 8) & 0xFF, regs[2] & 0xFF
            rising = action & rACT and not self.action & rACT
            self.action = action
            if not action & rACT:
                self.status, self.obj, self._moving = STA_RESET, OBJ_MOVING, False
                self._activation_started = None
                if action & rGTO:
                    self.fault = 7  # the activation bit must be set prior to an action
                elif self.fault in (5, 7):
                    self.fault = 0
                return
            if rising:
                if self.fault in MAJOR_FAULTS or self.fault in (5, 7):
                    self.fault = 0  # a rising edge on rACT clears faults
                self.status, self._activation_started = STA_ACTIVATING, self._t
            if action & rGTO:
                if self.status != STA_ACTIVE:
                    self.fault = 5  # action delayed: activation must complete first
                elif self.fault not in MAJOR_FAULTS:
                    self._moving, self.obj = True, OBJ_MOVING
            else:
                self._moving = False

    def inject_fault(self, code: int) -> None:
        with self.lock:
            self._advance()
            self.fault = code
            if code in MAJOR_FAULTS:
                self._moving = False

    def registers(self) -> list[int]:
        """The three status registers (gACT/gGTO/gSTA/gOBJ, FLT/gPR, gPO/gCU)."""
        with self.lock:
            self._advance()
            act = 1 if self.status == STA_ACTIVE or self.status == STA_ACTIVATING else 0
            gto = 1 if self.action & rGTO else 0
            byte0 = act | gto << 3 | self.status << 4 | self.obj << 6
            current = self.force // 4 if self.obj == OBJ_CONTACT_CLOSING else (3 if self._moving else 0)
            return [byte0 << 8, self.fault << 8 | self.request, round(self.position) << 8 | current]

    def _advance(self) -> None:
        now = self._now()
        dt, self._t = now - self._t, now
        if self.status == STA_ACTIVATING and now - self._activation_started >= self.spec.activation_time:
            self.status = STA_ACTIVE
        if not self._moving:
            return
        s = self.spec
        rate = (s.min_speed + (s.max_speed - s.min_speed) * self.speed / 255) / s.stroke * 255
        target = float(self.request)
        stop_at = None
        if s.object_width is not None:
            # Rigid fingers stop where they touch the object; soft pads give until they press
            # it with the requested force.
            squeezed = s.object_width
            if s.pad_stiffness:
                squeezed -= (s.min_force + (s.max_force - s.min_force) * self.force / 255) / s.pad_stiffness
            stop_at = (1.0 - squeezed / s.stroke) * 255
        step = rate * dt
        if target > self.position:  # closing
            if stop_at is not None and self.position <= stop_at < target and self.position + step >= stop_at:
                self.position, self._moving, self.obj = stop_at, False, OBJ_CONTACT_CLOSING
                return
            self.position = min(self.position + step, target)
        else:
            self.position = max(self.position - step, target)
        if self.position == target:
            self._moving, self.obj = False, OBJ_AT_REQUEST
