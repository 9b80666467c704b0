"""Benchmark metrics: marker error against ground truth, identity swaps, tracked share, slip F1,
Kalman jitter and step lag, and the no-ground-truth checks used on real footage."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from perception.fingervision import FingerVision


def match_truth(calibrated: np.ndarray, truth: np.ndarray, tol: float = 1.5) -> np.ndarray:
    """Index of the true marker under each calibrated one, -1 where none is within `tol` px."""
    d = np.linalg.norm(calibrated[:, None, :] - truth[None, :, :], axis=2)
    idx = d.argmin(axis=1)
    idx[d.min(axis=1) > tol] = -1
    return idx


@dataclass
class Track:
    """What a pipeline reported over a rendered sequence, in the true markers' terms."""

    rms: float  # px, over valid markers that are visible and matched (nan if none)
    tracked: float  # share of visible, matched markers reported valid (mean over frames)
    swaps: int  # valid markers nearer another marker's true position than their own (unflagged)
    times: np.ndarray  # s per frame
    off: float = 0.0  # share of valid samples more than 1 px from the truth (biased, yet trusted)


def run_sequence(fv: FingerVision, frames) -> tuple[list, np.ndarray]:
    """Process rendered frames; returns (states, per-frame process time)."""
    states, times = [], []
    for k, frame in enumerate(frames):
        t0 = time.perf_counter()
        states.append(fv.process(frame.image, k / fv.config.camera_fps))
        times.append(time.perf_counter() - t0)
    return states, np.array(times)


def score(fv: FingerVision, frames, truth_origin: np.ndarray) -> Track:
    """Run a calibrated pipeline over rendered frames and compare with their ground truth."""
    states, times = run_sequence(fv, frames)
    sq, n, tracked, swaps, off = 0.0, 0, [], 0, 0
    idx = np.zeros(0, int)
    for state, frame in zip(states, frames):
        if len(idx) != len(state.markers):  # calibrated, or markers added after calibration
            idx = match_truth(state.markers.origin, truth_origin)
            real = idx >= 0
        truth = frame.truth
        est = state.markers.position[real]
        own = truth.position[idx[real]]
        seen = truth.visible[idx[real]]
        valid = state.markers.valid[real] & seen
        err = np.linalg.norm(est - own, axis=1)
        sq += float((err[valid] ** 2).sum())
        off += int((err[valid] > 1.0).sum())
        n += int(valid.sum())
        tracked.append(valid.sum() / max(seen.sum(), 1))
        nearest = np.linalg.norm(est[:, None, :] - truth.position[None, :, :], axis=2).argmin(axis=1)
        swaps += int((valid & (nearest != idx[real])).sum())
    rms = float(np.sqrt(sq / n)) if n else float("nan")  # nan: nothing tracked at all
    return Track(rms, float(np.mean(tracked)), swaps, times, off / max(n, 1))


def best_threshold(score_values: np.ndarray, actual: np.ndarray) -> float:
    """The decision threshold on `score_values` with the best F1 (for tuning on a training run)."""
    candidates = np.unique(np.round(score_values, 4))
    return float(max(candidates, key=lambda t: f1(score_values > t, actual)))


def f1(predicted: np.ndarray, actual: np.ndarray) -> float:
    """F1 score of boolean predictions."""
    tp = float((predicted & actual).sum())
    fp = float((predicted & ~actual).sum())
    fn = float((~predicted & actual).sum())
    return 2 * tp / max(2 * tp + fp + fn, 1.0)


def jitter_and_lag(raw: np.ndarray, filtered: np.ndarray, truth: np.ndarray, at: int, step_px: float):
    """(static jitter reduction, step lag in frames) from per-frame mean x of the markers.

    Jitter: temporal std of each marker before the step (its fixed offset removed), raw over
    filtered. Lag: frames the filtered output needs, after the raw measurement, to come within
    10 % of the step."""
    before = slice(at // 3, at)
    jitter = float(raw[before].std(axis=0).mean() / max(filtered[before].std(axis=0).mean(), 1e-9))

    def settle(x):
        close = np.abs(x[at:] - truth[at:]).mean(axis=1) < 0.1 * step_px
        return int(np.argmax(close)) if close.any() else len(close)

    return jitter, settle(filtered) - settle(raw)


def real_swaps(position: np.ndarray, valid: np.ndarray, origin: np.ndarray) -> int:
    """Valid markers nearer another marker's expected place (origin + the field's median shift)."""
    if valid.sum() < 2:
        return 0
    shift = np.median(position[valid] - origin[valid], axis=0)
    expected = origin + shift
    nearest = np.linalg.norm(position[:, None, :] - expected[None, :, :], axis=2).argmin(axis=1)
    return int((valid & (nearest != np.arange(len(origin)))).sum())


def relative_jumps(position: np.ndarray, prev: np.ndarray, valid: np.ndarray, limit: float = 3.0) -> int:
    """Markers valid in both frames that moved more than `limit` px beyond the field's median step."""
    if valid.sum() < 2:
        return 0
    step = position - prev
    rel = np.linalg.norm(step - np.median(step[valid], axis=0), axis=1)
    return int((valid & (rel > limit)).sum())


def median_time(fn: Callable[[int], object], n: int) -> float:
    """Median wall time of fn(k) over k = 0..n-1, in seconds."""
    times = []
    for k in range(n):
        t0 = time.perf_counter()
        fn(k)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))
