"""Fit a fingertip skin's response time from a press-and-hold: the load a scale reads (the input,
sampled each tick) against what the markers show (the output), as a lab steps a load onto its sensor.

The model is the one the sensor profile describes (`skin_lag_s`, `skin_creep_share`, `skin_creep_s`,
`skin_hysteresis`): a standard linear solid whose fast branch follows the load with the lag, whose
slow branch carries the creep share with the creep time, and which unloads (1 + hysteresis) times
slower than it loads; discretised per sample as first-order holds, settled on the first sample.
The markers are taken as an offset plus a gain times that shown load (both solved linearly for every
trial of the time constants), so the gain calibrated elsewhere does not enter.

Two models are fitted by least squares: lag and hysteresis alone, and with creep. The creep is
reported only when it is told apart: it must lower the residual beyond what two more parameters buy
on noise (an F test), be at least `MIN_CREEP_SHARE`, and have a time constant shorter than the
record. The creep's time constant is fitted as a multiple (at least `MIN_CREEP_RATIO`) of the lag and
its share is at most `MAX_CREEP_SHARE` (silicone's range): a second branch as fast as the first, or
carrying most of the load, would be a lag split in two, not a creep. Otherwise the lag model stands and the creep is "not told apart" (None).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

MIN_CREEP_SHARE = 0.01  # a creep below 1 % of the load is not worth telling apart
F_SIGNIFICANCE = 1e-3  # the creep model must beat the lag model at this significance
LAG_BOUNDS = (1e-3, 5.0)  # s
MAX_CREEP_S = 30.0  # s
MIN_CREEP_RATIO = 3.0  # the creep at least this many times slower than the lag
MAX_CREEP_SHARE = 0.3
MAX_HYSTERESIS = 3.0


@dataclass(frozen=True)
class SkinFit:
    """A fitted skin response: the lag (s), the hysteresis, the creep share and time (None when not
    told apart from noise), the px shown per unit of input, and the fit's residual (px rms)."""

    lag_s: float
    hysteresis: float
    creep_share: float | None
    creep_s: float | None
    gain: float
    residual_px: float
    samples: int
    lag_only_residual_px: float  # the lag model's residual, to compare

    @property
    def creep_told_apart(self) -> bool:
        return self.creep_share is not None


def shown(u: np.ndarray, dt: float, lag: float, hysteresis: float, creep_share: float = 0.0,
          creep_s: float = 0.0) -> np.ndarray:
    """The load a skin shows for the sampled loads `u` (settled on u[0]), sample by sample."""
    fast = slow = float(u[0])
    up_fast, down_fast = _alphas(dt, lag, hysteresis)
    up_slow, down_slow = _alphas(dt, creep_s, hysteresis) if creep_share > 0.0 else (1.0, 1.0)
    out = np.empty(len(u))
    for k, load in enumerate(u.tolist()):
        fast += (load - fast) * (down_fast if abs(load) < abs(fast) else up_fast)
        slow += (load - slow) * (down_slow if abs(load) < abs(slow) else up_slow)
        out[k] = (1.0 - creep_share) * fast + creep_share * slow
    return out


def _alphas(dt: float, tau: float, hysteresis: float) -> tuple[float, float]:
    """The share of the gap closed per sample, loading and unloading."""
    if tau <= 0.0:
        return 1.0, 1.0
    return 1.0 - math.exp(-dt / tau), 1.0 - math.exp(-dt / (tau * (1.0 + hysteresis)))


def _project(s: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """Residual of y against offset + gain s (solved), and the gain."""
    a = np.column_stack([np.ones_like(s), s])
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    return y - a @ coef, float(coef[1])


def fit(u: Sequence[float], y: Sequence[float], dt: float) -> SkinFit:
    """Fit the skin's lag, hysteresis and (if told apart) creep to loads `u` and marker motion `y`,
    both sampled every `dt` s; `u` should step up and back down, each step held for seconds."""
    from scipy.optimize import least_squares
    from scipy.stats import f as f_dist

    u_arr, y_arr = np.asarray(u, float), np.asarray(y, float)
    if len(u_arr) != len(y_arr) or len(u_arr) < 20:
        raise ValueError("a skin response fit needs the same number (>= 20) of loads and marker samples")

    def lag_model(p: np.ndarray) -> np.ndarray:
        return _project(shown(u_arr, dt, math.exp(p[0]), p[1]), y_arr)[0]

    def creep_model(p: np.ndarray) -> np.ndarray:  # p[3]: log of the creep time over the lag
        return _project(shown(u_arr, dt, math.exp(p[0]), p[1], p[2], math.exp(p[0] + p[3])), y_arr)[0]

    lo, hi = math.log(LAG_BOUNDS[0]), math.log(LAG_BOUNDS[1])
    lag_fit = min((least_squares(lag_model, [math.log(tau), 0.3], bounds=([lo, 0.0], [hi, MAX_HYSTERESIS]),
                                 diff_step=[1e-3]) for tau in (0.03, 0.2, 1.0)), key=lambda r: r.cost)
    rlo, rhi = math.log(MIN_CREEP_RATIO), math.log(MAX_CREEP_S / LAG_BOUNDS[0])
    starts = [[lag_fit.x[0], lag_fit.x[1], 0.05, min(max(math.log(tc) - lag_fit.x[0], rlo + 0.01), rhi - 0.01)]
              for tc in (1.0, 3.0, 10.0)]
    creep_fit = min((least_squares(creep_model, x0, bounds=([lo, 0.0, 0.0, rlo], [hi, MAX_HYSTERESIS, MAX_CREEP_SHARE,
                                                                                  rhi]),
                                   diff_step=[1e-3]) for x0 in starts), key=lambda r: r.cost)
    n = len(y_arr)
    ss_lag, ss_creep = 2.0 * lag_fit.cost, 2.0 * creep_fit.cost
    dof = n - 6  # offset, gain, lag, hysteresis, creep share and time
    f_stat = (ss_lag - ss_creep) / 2.0 / max(ss_creep / dof, 1e-300)
    record_s = n * dt
    creep_s = math.exp(creep_fit.x[0] + creep_fit.x[3])
    told = (f_dist.sf(f_stat, 2, dof) < F_SIGNIFICANCE and creep_fit.x[2] >= MIN_CREEP_SHARE
            and creep_s < min(record_s, MAX_CREEP_S))
    best = creep_fit if told else lag_fit
    p = best.x
    s = shown(u_arr, dt, math.exp(p[0]), p[1], *((p[2], creep_s) if told else ()))
    residual, gain = _project(s, y_arr)
    return SkinFit(lag_s=math.exp(p[0]), hysteresis=float(p[1]), creep_share=float(p[2]) if told else None,
                   creep_s=creep_s if told else None, gain=gain, residual_px=float(np.sqrt(np.mean(residual ** 2))),
                   samples=n, lag_only_residual_px=float(np.sqrt(ss_lag / n)))
