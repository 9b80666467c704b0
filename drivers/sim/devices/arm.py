"""Kinematic arm: commanded linear moves and twists integrated once per tick, with limits."""

from __future__ import annotations

import math

import numpy as np

from drivers.protocols import Clock
from drivers.sim.transforms import matrix_to_rotvec, rotvec_to_matrix


class KinematicArm:
    """A TCP that moves exactly as commanded, within its own speed limits (no dynamics)."""

    def __init__(
        self,
        clock: Clock,
        pose: np.ndarray,
        max_speed: float = 1.0,
        max_angular_speed: float = 1.5,
    ):
        self.clock = clock
        self._pose = np.array(pose, dtype=float)
        self.max_speed = max_speed
        self.max_angular_speed = max_angular_speed
        self._twist = [0.0] * 6  # commanded twist (speed mode)
        self._target: np.ndarray | None = None  # commanded pose (move mode)
        self._target_speed = 0.0
        self._velocity = [0.0] * 6  # what the TCP actually did last step
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
        self._target = np.array(pose, dtype=float)
        self._target_speed = min(float(speed), self.max_speed)
        self._twist = [0.0] * 6

    def speed_linear(self, twist: np.ndarray) -> None:
        self._target = None
        self._twist = np.array(twist, dtype=float).tolist()

    def is_moving(self) -> bool:
        return self._target is not None or any(self._twist)

    def stop(self) -> None:
        self._target = None
        self._twist = [0.0] * 6

    def fault(self) -> str | None:
        return self.fault_text

    # Simulation -------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Move the TCP for `dt` seconds (on Python floats: numpy costs more than it saves on 3 numbers)."""
        before = self._pose.tolist()
        if self._target is not None:
            self._step_towards_target(dt, before)
        elif any(self._twist):
            self._step_twist(dt, before)
        after = self._pose.tolist()
        self._velocity[:3] = [(after[0] - before[0]) / dt, (after[1] - before[1]) / dt, (after[2] - before[2]) / dt]

    def _step_twist(self, dt: float, p: list[float]) -> None:
        """Move from pose `p` at the commanded twist, its speed capped."""
        (vx, vy, vz), w = self._twist[:3], self._twist[3:]
        n = math.hypot(vx, vy, vz)
        if n > self.max_speed:
            k = self.max_speed / n
            vx, vy, vz = vx * k, vy * k, vz * k
        self._pose[:3] = [p[0] + vx * dt, p[1] + vy * dt, p[2] + vz * dt]
        if any(w):
            rot = rotvec_to_matrix([x * dt for x in w]) @ rotvec_to_matrix(p[3:])
            self._pose[3:] = matrix_to_rotvec(rot)

    def _step_towards_target(self, dt: float, p: list[float]) -> None:
        """Move from pose `p` towards the commanded pose at the commanded speed; turn within the limit."""
        target = self._target.tolist()
        delta = [target[0] - p[0], target[1] - p[1], target[2] - p[2]]
        dist = math.hypot(*delta)
        reach = self._target_speed * dt
        if dist <= reach:
            self._pose[:3] = target[:3]
        else:
            k = reach / dist
            self._pose[:3] = [p[0] + delta[0] * k, p[1] + delta[1] * k, p[2] + delta[2] * k]
        arrived_rot = True
        if max(abs(target[3] - p[3]), abs(target[4] - p[4]), abs(target[5] - p[5])) > 1e-9:
            cur = rotvec_to_matrix(p[3:])
            err = matrix_to_rotvec(rotvec_to_matrix(target[3:]) @ cur.T)
            angle = math.hypot(*err.tolist())
            max_step = self.max_angular_speed * dt
            if angle > max_step:
                err *= max_step / angle
                arrived_rot = False
            self._pose[3:] = matrix_to_rotvec(rotvec_to_matrix(err) @ cur)
        if dist <= reach and arrived_rot:
            self._pose[3:] = target[3:]
            self._target = None
