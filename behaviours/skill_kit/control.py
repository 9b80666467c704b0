"""Small control laws shared by skills: leaky integrator (and the gentle opening through it that
place_element and release share), SpeedCtrl and the force-change detector of gentle grasping."""

from __future__ import annotations

from collections import deque

import numpy as np


class LeakyIntegrator:
    """x_t = a x_{t-1} - (1 - a) L: follows the input -L with inertia set by `a` (0..1)."""

    def __init__(self, alpha: float, x0: float = 0.0):
        if not 0.0 <= alpha < 1.0:
            raise ValueError(f"leaky integrator alpha must be in [0, 1), got {alpha}")
        self.alpha = alpha
        self.x = x0

    def step(self, drive: float) -> float:
        self.x = self.alpha * self.x - (1.0 - self.alpha) * drive
        return self.x


def speed_ctrl_gain(v_min: float, v_max: float, f_min: float, f_max: float) -> float:
    """SpeedCtrl alpha = (v_max - v_min) / (f_max - f_min): maps the force range to speeds."""
    if f_max <= f_min:
        raise ValueError(f"f_max ({f_max}) must exceed f_min ({f_min})")
    return (v_max - v_min) / (f_max - f_min)


class ForceChangeDetector:
    """Fires when more than `min_markers` markers moved more than `threshold` from the
    reference field taken over the first `reference_frames` frames (2023 gentle-grasp rule).
    Each finger's markers are compared with its own reference, index by index: markers the pipeline
    adopts after the reference (it appends markers missed at calibration, e.g. under glare) have no
    reference and are not counted."""

    def __init__(self, threshold: float, min_markers: int, reference_frames: int = 3):
        self.threshold = threshold
        self.min_markers = min_markers
        self.reference_frames = reference_frames
        self._ref: list[tuple[np.ndarray, ...]] = []
        self._mean: list[np.ndarray] | None = None  # per finger, the reference field once its frames are in
        self.changed = 0

    def update(self, *marker_forces: np.ndarray) -> bool:
        """Feed this frame's per-marker forces (one array per finger); True when it fires."""
        if len(self._ref) < self.reference_frames:
            self._ref.append(marker_forces)
            return False
        if self._mean is None:  # averaged once: the reference frames do not change after
            counts = [min(len(frame[i]) for frame in self._ref) for i in range(len(marker_forces))]
            self._mean = [np.mean([frame[i][:n] for frame in self._ref], axis=0) for i, n in enumerate(counts)]
        self.changed = 0
        for f, mean in zip(marker_forces, self._mean):
            n = min(len(f), len(mean))
            self.changed += int(np.count_nonzero(np.linalg.norm(f[:n] - mean[:n], axis=1) > self.threshold))
        return self.changed > self.min_markers


class MovingAverage:
    """Mean of the last `n` vectors."""

    def __init__(self, n: int):
        self._buf: deque = deque(maxlen=n)

    def update(self, value) -> np.ndarray:
        self._buf.append(np.asarray(value, dtype=float))
        return np.mean(self._buf, axis=0)


def speed_ctrl(force: np.ndarray, v_min: float, v_max: float, f_min: float, f_max: float,
               eps: float) -> np.ndarray:
    """SpeedCtrl per axis: |f| in [f_min, f_max] maps linearly onto speeds [v_min, v_max]
    (alpha = speed_ctrl_gain), along the sign of f; axes with |f| <= eps stay still."""
    f = np.asarray(force, dtype=float)
    alpha = speed_ctrl_gain(v_min, v_max, f_min, f_max)
    speed = np.clip(v_min + alpha * (np.abs(f) - f_min), v_min, v_max)
    return np.where(np.abs(f) > eps, np.sign(f) * speed, 0.0)


def leaky_open(skill, target: float, alpha: float, max_time: float, speed: float = 0.05):
    """Steps of a ProgramSkill (`yield from`) opening its gripper from the current width to
    `target` through the leaky integrator with L = -1 (the opening goes 0 -> 1 with inertia
    `alpha`); returns None once open, or why not (a gripper fault, or not open within
    `max_time`). The skill needs /gripper/width and /gripper/fault in READS."""
    gripper = skill.cell.gripper
    start, t0 = skill.gripper_width(), skill.now()
    drive = LeakyIntegrator(alpha)
    while skill.gripper_width() < target - 1e-4:
        if skill.now() - t0 > max_time:
            gripper.stop()
            return (f"the fingers opened to {skill.gripper_width() * 1000:.1f} mm of {target * 1000:.1f} mm "
                    f"within {max_time:.0f} s")
        gripper.move(start + drive.step(-1.0) * (target - start), speed=speed)
        yield
        fault = skill.gripper_fault()
        if fault:
            return f"gripper fault: {fault}"
    return None
