"""The simulated arm: commanded linear moves and twists, with a UR controller's command latency and
acceleration limits (`drivers.sim.devices.arm_motion`; none by default: the kinematic arm)."""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from drivers.protocols import Clock
from drivers.sim.devices.arm_motion import CONTROL_PERIOD, IDEAL, ArmMotion, approach_speed, ramp
from drivers.sim.transforms import matrix_to_rotvec, rotvec_to_matrix

ZERO = [0.0, 0.0, 0.0]


class KinematicArm:
    """A TCP that moves as commanded, within its speed limits and, with `motion`, a command latency
    and acceleration limits: a command takes effect `motion.latency` s after it is sent, then the
    TCP's velocity ramps towards it (sub-stepped at the controller's 2 ms cycle while it changes)."""

    def __init__(
        self,
        clock: Clock,
        pose: np.ndarray,
        max_speed: float = 1.0,
        max_angular_speed: float = 1.5,
        motion: ArmMotion = IDEAL,
    ):
        self.clock = clock
        self._pose = np.array(pose, dtype=float)
        self.max_speed = max_speed
        self.max_angular_speed = max_angular_speed
        self.motion = motion
        self._ideal = motion.ideal  # read every sub-step (the motion settings are frozen)
        self._twist = [0.0] * 6  # commanded twist in effect (speed mode)
        self._target: np.ndarray | None = None  # commanded pose in effect (move mode)
        self._goal: list[float] = []  # the same pose as Python floats, read every sub-step
        self._goal_rotation = np.eye(3)  # its rotation matrix
        self._start_rotation: np.ndarray | None = None  # the pose's rotation matrix as this step began
        self._target_speed = 0.0
        self._stopping = False  # a stop in effect: decelerate at motion.stop_deceleration
        self._turned = False  # the move in effect has reached its orientation
        self._pending: deque[tuple[float, str, tuple]] = deque()  # (due, command, args) sent, not yet in effect
        self._t = 0.0  # the arm's own time: the sum of its steps
        self._v = list(ZERO)  # TCP linear velocity (m/s, base frame)
        self._w = list(ZERO)  # TCP angular velocity (rad/s, base frame)
        self._velocity = [0.0] * 6  # what the TCP did at the end of the last step
        self.external_wrench = np.zeros(6)  # set by the scene from contacts
        self.fault_text: str | None = None

    # Arm protocol -----------------------------------------------------------------------
    def pose(self) -> np.ndarray:
        return self._pose.copy()

    def tcp_speed(self) -> np.ndarray:
        return np.array(self._velocity)

    def tcp_wrench(self) -> np.ndarray:
        return self.external_wrench.copy()

    def state_stamp(self) -> float:
        return self.clock.now()

    def move_linear(self, pose: np.ndarray, speed: float) -> None:
        self._send("move", (np.array(pose, dtype=float), min(float(speed), self.max_speed)))

    def speed_linear(self, twist: np.ndarray) -> None:
        self._send("twist", (np.array(twist, dtype=float).tolist(),))

    def is_moving(self) -> bool:
        """Moving, or about to: a motion command sent and not yet in effect counts."""
        if any(kind == "move" or (kind == "twist" and any(args[0])) for _, kind, args in self._pending):
            return True
        return self._target is not None or any(self._twist) or any(self._v) or any(self._w)

    def stop(self) -> None:
        self._send("stop", ())

    def fault(self) -> str | None:
        return self.fault_text

    def braking_distance(self, speed: float) -> float:
        """Metres the TCP travels after a command to slow from `speed` m/s is sent: the latency at
        that speed, then the ramp to rest (what the safety layer adds to its look-ahead at the box)."""
        accel = self.motion.acceleration
        return speed * self.motion.latency + (speed * speed / (2.0 * accel) if accel > 0.0 else 0.0)

    # Commands in flight -----------------------------------------------------------------
    def _send(self, kind: str, args: tuple) -> None:
        if self.motion.latency <= 0.0:
            self._apply(kind, args)
        else:
            self._pending.append((self._t + self.motion.latency, kind, args))

    def _apply(self, kind: str, args: tuple) -> None:
        """Put a command in effect."""
        self._target, self._twist, self._stopping = None, [0.0] * 6, False
        if kind == "move":
            self._target, self._target_speed = args
            self._goal = self._target.tolist()
            self._goal_rotation = rotvec_to_matrix(self._goal[3:6])
            self._turned = False
        elif kind == "twist":
            self._twist = args[0]  # a zero twist ramps down at the acceleration, as speedL does
        else:
            self._stopping = True
        decel = self.motion.stop_deceleration if self._stopping else self.motion.acceleration
        if decel <= 0.0 and not any(self._twist) and self._target is None:
            self._v, self._w, self._velocity = list(ZERO), list(ZERO), [0.0] * 6  # stops at once
            self._stopping = False

    def _apply_due(self, t: float) -> float:
        """Put the commands due by `t` in effect; the time the next one falls due (inf: none)."""
        while self._pending and self._pending[0][0] <= t + 1e-12:
            _, kind, args = self._pending.popleft()
            self._apply(kind, args)
        return self._pending[0][0] if self._pending else math.inf

    # Simulation -------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Move the TCP for `dt` seconds (on Python floats: numpy costs more than it saves on 3 numbers)."""
        t, end = self._t, self._t + dt
        turn = list(ZERO)  # rotation vector turned in this step (the axis barely changes within a tick)
        pose = self._pose.tolist()  # the sub-steps move its position, written back once at the end
        self._start_rotation = None  # the pose turns at the end of the step: its matrix is made once a step
        while end - t > 1e-12:
            due = self._apply_due(t) if self._pending else math.inf  # as `_apply_due` says with none in flight
            h = min(end, due) - t
            h = self._advance(h, pose, turn)
            t += h
        self._pose[:3] = pose[:3]
        self._t = end
        self._apply_due(end)
        if self._target is not None and self._turned:
            self._pose[3:] = self._target[3:]  # exactly: rotation vectors near pi carry 1e-5 of rounding
        elif any(turn):
            self._pose[3:] = matrix_to_rotvec(rotvec_to_matrix(turn).dot(rotvec_to_matrix(self._pose[3:])))
        if self._target is not None and self._turned and not any(self._v) and pose[:3] == self._goal[:3]:
            self._target = None
        self._velocity = self._v + self._w

    def _advance(self, h: float, p: list[float], turn: list[float]) -> float:
        """Move the position of the pose `p` (x, y, z, rotation vector) for at most `h` s under the
        command in effect, adding the rotation to `turn`; returns the time taken (a controller cycle
        while the velocity changes, else all of `h`). `approach_speed` and `ramp` are written out
        here with the same arithmetic: this runs up to 17 times a tick while the arm accelerates."""
        motion = self.motion
        stopping, target = self._stopping, self._target
        accel, ang_accel = (motion.stop_deceleration,) * 2 if stopping else (
            motion.acceleration, motion.angular_acceleration)
        axis, angle, dist = ZERO, 0.0, 0.0
        v, w = self._v, self._w
        if target is not None:
            goal = self._goal
            left = [goal[0] - p[0], goal[1] - p[1], goal[2] - p[2]]
            dist = math.hypot(*left)
            cruise = self._target_speed
            speed = min(cruise, math.sqrt(2.0 * accel * dist)) if accel > 0.0 else min(cruise, dist / h)
            v_goal = [x / dist * speed for x in left] if dist > 1e-12 else list(ZERO)
            if self._turned:
                w_goal = list(ZERO)  # approach_speed of no angle is 0: [a * 0.0 for a in ZERO]
            else:
                axis, angle = self._rotation_left(p, goal, turn)
                rate = approach_speed(angle, self.max_angular_speed, ang_accel, h)
                w_goal = [a * rate for a in axis]
            steady = (speed == cruise and _close(v_goal, v) and not angle and not any(w)
                      and cruise * h + _stopping(speed, accel) < dist)
        elif stopping:
            v_goal, w_goal, steady = list(ZERO), list(ZERO), False
        else:
            vx, vy, vz = self._twist[:3]
            n = math.hypot(vx, vy, vz)
            k = self.max_speed / n if n > self.max_speed else 1.0
            v_goal, w_goal = [vx * k, vy * k, vz * k], list(self._twist[3:])
            steady = _close(v_goal, v) and _close(w_goal, w)
        if not (steady or self._ideal):
            h = min(h, CONTROL_PERIOD)
        v0 = v
        self._v = v = ramp(v0, v_goal, accel * h)
        # not turning and asked not to: ramp's answer, list(w_goal), without its arithmetic on zeros
        self._w = w = list(w_goal) if not any(w) and not any(w_goal) else ramp(w, w_goal, ang_accel * h)
        step = [(a + b) * 0.5 * h for a, b in zip(v0, v)] if accel > 0.0 else [b * h for b in v]
        if target is not None and dist <= max(math.hypot(*step), 1e-9):
            p[:3], self._v = self._goal[:3], list(ZERO)  # the position arrives within this sub-step
        else:
            p[0] += step[0]
            p[1] += step[1]
            p[2] += step[2]
        rotated = [w[0] * h, w[1] * h, w[2] * h]
        if target is not None and not self._turned and angle <= math.hypot(*rotated):
            rotated, self._w, self._turned = [a * angle for a in axis], list(ZERO), True  # so does the orientation
        turn[0] += rotated[0]
        turn[1] += rotated[1]
        turn[2] += rotated[2]
        if stopping and not any(self._v) and not any(self._w):
            self._stopping = False
        return h

    def _rotation_left(self, pose: list[float], target: list[float], turn: list[float]) -> tuple[list[float], float]:
        """Unit axis and angle (rad) from the present orientation (`pose`'s, after `turn`) to the target's."""
        if max(abs(target[3] - pose[3]), abs(target[4] - pose[4]), abs(target[5] - pose[5])) <= 1e-9:
            return list(ZERO), 0.0
        if self._start_rotation is None:
            self._start_rotation = rotvec_to_matrix(pose[3:6])
        # `dot` is numpy's `@` on 3x3 matrices (the same BLAS product, the same bits) at half the cost a call
        cur = rotvec_to_matrix(turn).dot(self._start_rotation) if any(turn) else self._start_rotation
        err = matrix_to_rotvec(self._goal_rotation.dot(cur.T)).tolist()
        angle = math.hypot(*err)
        if angle < 1e-9:
            return list(ZERO), 0.0
        return [e / angle for e in err], angle


def _close(a: list[float], b: list[float]) -> bool:
    """Whether two 3-vectors agree within 1e-12 in every component."""
    return abs(a[0] - b[0]) < 1e-12 and abs(a[1] - b[1]) < 1e-12 and abs(a[2] - b[2]) < 1e-12


def _stopping(speed: float, accel: float) -> float:
    """Distance to stop from `speed` at `accel` (0: at once)."""
    return speed * speed / (2.0 * accel) if accel > 0.0 else 0.0
