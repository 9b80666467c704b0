"""How much of a lagging skin's answer is still to come, measured on the spot.

A viscoelastic skin shows a load over its time constant (silicone: 0.03-2 s), so a skill that takes
a reference while the skin still answers an earlier load (a grasp, a carry, a hand-over) sees the
rest of that answer later as a change of its own. `relaxation` extrapolates it from a window of
readings: for a first-order answer x(t) = x_inf + c e^(-t/tau), the changes between the means of
three equal stretches of the window shrink by r = e^(-h/tau) (h: one stretch), and what is left to
come after the last is d2 r / (1 - r) (Aitken's extrapolation of a geometric series; less from the
window's newest reading on, by the decay between them). It needs no
time constant from the sensor profile (a lab's profile is never exactly its skin) and gives the
skin's time constant as a by-product. `Settling` feeds it tick by tick and says when the rest is
below a tolerance.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

MAD_TO_SIGMA = 1.4826  # a normal noise's standard deviation per median absolute deviation


@dataclass(frozen=True)
class Relaxation:
    """What a window of readings says of the skin's answer still to come."""

    remaining: np.ndarray  # change still to come after the newest reading, per axis (inf: it does not settle)
    lag: float | None  # s, the time constant the window's decay shows (None: no decay measurable)
    noise: float  # per-axis standard deviation of one reading's noise

    @property
    def size(self) -> float:
        """The length of `remaining`."""
        return float(np.linalg.norm(self.remaining))


def reading_noise(readings) -> float:
    """Per-axis standard deviation of one reading's white noise, from the tick-to-tick steps of
    `readings` (at least 3): their median absolute deviation (so neither the answer's slow drift nor
    one sudden step, a person's tug, is taken for noise), pooled over the axes; a step of white noise
    has sqrt(2) times its spread."""
    x = np.asarray(readings, dtype=float)
    steps = np.diff(x.reshape(len(x), -1), axis=0)
    if len(steps) < 2:
        raise ValueError(f"need at least 3 readings to measure their noise, got {len(x)}")
    mad = np.median(np.abs(steps - np.median(steps, axis=0)), axis=0) * MAD_TO_SIGMA
    return float(np.sqrt(np.mean(mad ** 2) / 2.0))


def relaxation(readings, period: float) -> Relaxation:
    """The relaxation still to come after `readings` (one vector per tick, oldest first, at least 6,
    `period` s apart): Aitken's extrapolation over the means of the window's last three equal
    stretches. No change across the window beyond its means' noise is no change: nothing is left
(the window must span about the skin's time constant to see a slower one move)."""
    x = np.asarray(readings, dtype=float)
    x = x.reshape(len(x), -1)
    n = len(x) // 3
    if n < 2:
        raise ValueError(f"need at least 6 readings to measure a relaxation, got {len(x)}")
    parts = x[len(x) - 3 * n:].reshape(3, n, -1)
    a, b, c = parts.mean(axis=1)
    noise = reading_noise(x[len(x) - 3 * n:])
    d1, d2 = b - a, c - b
    step_noise = 3.0 * noise * math.sqrt(2.0 / n)  # a change of a stretch's mean beyond this is real
    if np.linalg.norm(c - a) <= step_noise:  # no change across the window: a skin whose lag it spans has settled
        return Relaxation(np.zeros_like(d2), None, noise)
    denom = float(d1 @ d1)
    r = float(d2 @ d1) / denom if denom > 0.0 else 1.0
    # The decay ratio as slow as the noise allows (two standard errors): a noisy window must not
    # promise a fast decay, which would call a skin settled with most of its answer still to come.
    r_err = noise * math.sqrt(2.0 / n) * math.sqrt(1.0 + r * r) / math.sqrt(denom) if denom > 0.0 else np.inf
    lag = -n * period / math.log(r) if 0.0 < r < 1.0 else None
    r = r + 2.0 * r_err
    if r >= 1.0 or r <= 0.0:  # not decaying (still ramping, or too noisy to tell), or a new load came in
        return Relaxation(np.full_like(d2, np.inf), lag, noise)
    # d2 r / (1 - r) is what is left after the last stretch's mean; from its newest reading on, less by
    # the mean of e^(j period / tau) over the stretch's n ticks (q = e^(-period / tau) = r^(1/n)).
    q = r ** (1.0 / n)
    newest = n * r * (1.0 - q) / (q * (1.0 - r))
    return Relaxation(d2 * r / (1.0 - r) * newest, lag, noise)


class Settling:
    """Watches a reading until the skin has shown what it will: `update` takes this tick's reading
    and says whether the relaxation still to come (over the last `window` readings) is within
    `tolerance`."""

    def __init__(self, window: int, tolerance: float, period: float):
        if window < 6:
            raise ValueError(f"a settling window needs at least 6 ticks, got {window}")
        self.tolerance, self.period = tolerance, period
        self._seen: deque[np.ndarray] = deque(maxlen=window)
        self.last: Relaxation | None = None

    @property
    def noise(self) -> float | None:
        """One reading's noise (`reading_noise`) from the readings so far; None before 6."""
        return reading_noise(self._seen) if len(self._seen) >= 6 else None

    def update(self, reading) -> bool:
        """Add this tick's reading; True once the window is full and what is still to come is within
        the tolerance."""
        self._seen.append(np.asarray(reading, dtype=float))
        if len(self._seen) < (self._seen.maxlen or 0):
            return False
        self.last = relaxation(self._seen, self.period)
        return self.last.size <= self.tolerance
