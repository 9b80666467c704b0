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
        self._twist = np.zeros(6)  # commanded twist (speed mode)
        self._target: np.ndarray | None = None  # commanded pose (move mode)
        self._target_speed = 0.0
        self._velocity = np.zeros(6)  # what the TCP actually did last step
        self.external_wrench = np.zeros(6)  # set by the scene from contacts
        self.fault_text: str | None = None

    # Arm protocol -----------------------------------------------------------------------
    def pose(self) -> np.ndarray:
        return self._pose.copy()

    def tcp_speed(self) -> np.ndarray:
        return self._velocity.copy()

    def tcp_wrench(self) -> np.ndarray:
        return self.external_wrench.copy()

    def state_stamp(self) -> float:
        return self.clock.now()

    def move_linear(self, pose: np.ndarray, speed: float) -> None:
        self._target = np.array(pose, dtype=float)
        self._target_speed = min(float(speed), self.max_speed)
        self._twist[:] = 0.0

    def speed_linear(self, twist: np.ndarray) -> None:
        self._target = None
        self._twist = np.array(twist, dtype=float)

    def is_moving(self) -> bool:
        return self._target is not None or bool(self._twist.any())

    def stop(self) -> None:
        self._target = None
        self._twist[:] = 0.0

    def fault(self) -> str | None:
        return self.fault_text

    # Simulation -------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        before = self._pose.copy()
        if self._target is not None:
            self._step_towards_target(dt)
        elif self._twist.any():
            v = self._twist[:3]
            n = math.hypot(*v.tolist())
            if n > self.max_speed:
                v = v * (self.max_speed / n)
            self._pose[:3] += v * dt
            w = self._twist[3:]
            if w.any():
                rot = rotvec_to_matrix(w * dt) @ rotvec_to_matrix(self._pose[3:])
                self._pose[3:] = matrix_to_rotvec(rot)
        self._velocity[:3] = (self._pose[:3] - before[:3]) / dt

    def _step_towards_target(self, dt: float) -> None:
        target = self._target
        delta = target[:3] - self._pose[:3]
        dist = math.hypot(*delta.tolist())
        reach = self._target_speed * dt
        self._pose[:3] = target[:3] if dist <= reach else self._pose[:3] + delta * (reach / dist)
        arrived_rot = True
        if np.abs(target[3:] - self._pose[3:]).max() > 1e-9:
            cur = rotvec_to_matrix(self._pose[3:])
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
