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
    """Fires when more than `min_markers` markers moved more than the contact limit from the
    reference field taken over the first `reference_frames` frames (2023 gentle-grasp rule).
    Each finger's markers are compared with its own reference, index by index: markers the pipeline
    adopts after the reference (it appends markers missed at calibration, e.g. under glare) have no
    reference and are not counted. The limit is `threshold`, raised to `noise_factor` times the rest
    noise measured on the reference frames (per axis, of a frame against their mean, pooled over the
    markers, and each marker's own where that is larger): a noisier skin than the one the threshold was set on (the calibration logs' rest jitter
    spans 0.046-0.32 px) would otherwise light enough markers to fire without any touch; at 4 times
    the noise a marker's noise crosses the limit on one frame in ~3000."""

    def __init__(self, threshold: float, min_markers: int, reference_frames: int = 3, noise_factor: float = 4.0):
        self.threshold = threshold
        self.min_markers = min_markers
        self.reference_frames = reference_frames
        self.noise_factor = noise_factor
        self._ref: list[tuple[np.ndarray, ...]] = []
        self._mean: list[np.ndarray] | None = None  # per finger, the reference field once its frames are in
        self._limits: list[np.ndarray] = []  # per finger, each marker's own limit (px)
        self.limit = threshold  # px a marker must move to count, once the reference is in
        self.changed = 0

    def update(self, *marker_forces: np.ndarray) -> bool:
        """Feed this frame's per-marker forces (one array per finger); True when it fires."""
        if len(self._ref) < self.reference_frames:
            self._ref.append(marker_forces)
            return False
        if self._mean is None:  # averaged once: the reference frames do not change after
            counts = [min(len(frame[i]) for frame in self._ref) for i in range(len(marker_forces))]
            frames = [np.array([frame[i][:n] for frame in self._ref], dtype=float) for i, n in enumerate(counts)]
            self._mean = [f.mean(axis=0) for f in frames]
            self.limit = max(self.threshold, self.noise_factor * rest_noise(frames))
            self._limits = [np.maximum(self.limit, self.noise_factor * marker_noise(f)) for f in frames]
        self.changed = 0
        for f, mean, limits in zip(marker_forces, self._mean, self._limits):
            n = min(len(f), len(mean))
            self.changed += int(np.count_nonzero(np.linalg.norm(f[:n] - mean[:n], axis=1) > limits[:n]))
        return self.changed > self.min_markers

    def deviation(self, *marker_forces: np.ndarray) -> np.ndarray:
        """Per finger, the mean over its referenced markers of how far each moved from the reference
        (px; 0 before the reference is in): a reading that grows with the load on the skin, for
        watching it settle after the fingers stop."""
        if self._mean is None:
            return np.zeros(len(marker_forces))
        out = np.zeros(len(marker_forces))
        for k, (f, mean) in enumerate(zip(marker_forces, self._mean)):
            n = min(len(f), len(mean))
            if n:
                out[k] = float(np.nanmean(np.linalg.norm(f[:n] - mean[:n], axis=1)))
        return out


def marker_noise(frames: np.ndarray) -> np.ndarray:
    """Each marker's own rest noise (per-axis standard deviation over `frames`, frames x markers x
    axes; 0 with fewer than two frames): a few markers of a real image (at the edge, under glare)
    are noisier than the pooled figure says, and would light up on their own."""
    if len(frames) < 2:
        return np.zeros(frames.shape[1])
    spread = np.nanmean(np.nanvar(frames, axis=0, ddof=1), axis=-1)
    return np.sqrt(np.nan_to_num(spread))


def rest_noise(fingers: list[np.ndarray]) -> float:
    """Per-axis standard deviation of one frame's marker forces against the mean of `fingers`' reference
    frames (each an array frames x markers x axes), pooled over fingers, markers and axes (0 with fewer
    than two frames)."""
    deviations = [(f - np.nanmean(f, axis=0)) ** 2 for f in fingers if len(f) >= 2 and f.size]
    if not deviations:
        return 0.0
    n = len(fingers[0])
    spread = np.nanmean(np.concatenate([d.ravel() for d in deviations])) * n / (n - 1)
    return float(np.sqrt(spread * (1.0 + 1.0 / n))) if np.isfinite(spread) else 0.0


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
