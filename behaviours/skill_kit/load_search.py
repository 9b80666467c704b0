"""Peak of a noisy load profile from a continuous scan: smooth, take the best sample, then fit
a local quadratic around it (robust under noise, where a golden-section search over single noisy
samples is not); and how clearly the profile peaks, so a scan that found no real maximum is not
trusted, and how sharp its top is: a beam's load changes smoothly along it, so a top much
narrower than that means the load was cut off (the grip gave way), not a maximum of the plate."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TOP = 0.03  # the top of a profile: within 3 % of its smoothed maximum ...
TOP_NOISE = 5.0  # ... or within 5 standard deviations of the smoothed profile's noise, if wider


@dataclass(frozen=True)
class PeakEstimate:
    position: float  # best position along the scan
    load: float  # load there (fitted where the fit holds)
    sample_position: float  # position of the best smoothed sample
    smoothed: np.ndarray
    coefficients: np.ndarray | None  # quadratic a x^2 + b x + c around the peak, if concave
    noise: float  # std of the samples about the smoothed profile
    prominence: float  # smoothed peak above the higher of the lowest points on either side
    top_share: float  # share of the scan around the peak where the smoothed load is within the top band

    @property
    def clarity(self) -> float:
        """Prominence in units of the sample noise: how clearly the profile peaks inside the
        scan (0 when the best sample is at an end of the scan, so the maximum may lie beyond)."""
        return self.prominence / max(self.noise, 1e-9)


def moving_average(y: np.ndarray, n: int) -> np.ndarray:
    """Centred mean over `n` samples, shrinking the window at the ends (no edge bias to 0)."""
    n = min(n, len(y))  # np.convolve(mode="same") returns the longer of the two: keep y's length
    if n <= 1:
        return y.astype(float)
    kernel = np.ones(n)
    sums = np.convolve(y, kernel, mode="same")
    counts = np.convolve(np.ones_like(y, dtype=float), kernel, mode="same")
    return sums / counts


def locate_peak(x, y, smooth_window: float, fit_half_width: float) -> PeakEstimate:
    """Estimate where the load y(x) peaks; `smooth_window` and `fit_half_width` in x units."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if len(x) < 5 or len(x) != len(y):
        raise ValueError(f"need at least 5 paired samples to locate a peak, got {len(x)}")
    order = np.argsort(x)
    x, y = x[order], y[order]
    spacing = (x[-1] - x[0]) / (len(x) - 1)
    n = max(1, round(smooth_window / spacing)) if spacing > 0 else 1
    smoothed = moving_average(y, n)
    i = int(np.argmax(smoothed))
    noise = float(np.std(y - smoothed))
    prominence = float(smoothed[i] - max(smoothed[: i + 1].min(), smoothed[i:].min()))
    band = max(TOP * abs(smoothed[i]), TOP_NOISE * noise / np.sqrt(n))  # a faint profile's top is its noise
    top_share = _top_width(x, smoothed, i, band) / max(x[-1] - x[0], 1e-12)
    near = np.abs(x - x[i]) <= fit_half_width
    if near.sum() >= 5:
        coeffs = np.polyfit(x[near] - x[i], y[near], 2)
        if coeffs[0] < 0:
            vertex = -coeffs[1] / (2 * coeffs[0])
            if abs(vertex) <= fit_half_width:
                best = x[i] + vertex
                return PeakEstimate(float(best), float(np.polyval(coeffs, vertex)), float(x[i]),
                                    smoothed, coeffs, noise, prominence, top_share)
    return PeakEstimate(float(x[i]), float(smoothed[i]), float(x[i]), smoothed, None, noise, prominence, top_share)


def _top_width(x: np.ndarray, smoothed: np.ndarray, i: int, band: float) -> float:
    """Width (x units) of the run of samples around the best one `i` within `band` of its load."""
    high = smoothed >= smoothed[i] - band
    lo = hi = i
    while lo > 0 and high[lo - 1]:
        lo -= 1
    while hi < len(x) - 1 and high[hi + 1]:
        hi += 1
    return float(x[hi] - x[lo])
