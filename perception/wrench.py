"""Force and torque from the marker field (FingerVision `fv_filter1` conventions).

Per marker, with displacement (dx, dy) and normal component fz:
  right finger: f = [+dx, -fz, -dy], lever p = [+rx, -ry]
  left finger:  f = [-dx, +fz, -dy], lever p = [-rx, -ry]
where r is the marker origin relative to the image centre divided by (W + H) / 2, and the
torque is cross([p0, 0, p1], f). Index 1 of the force is the finger normal; units are pixels
unless a calibration gives scale factors. Only valid markers enter the average.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from perception.state import MarkerField

NormalMode = Literal["xy_norm", "marker_size"]
Averaging = Literal["mean", "median", "robust"]

_SIGNS = {
    # finger: (force sign per [dx, fz, dy] column, lever sign per [rx, ry])
    "right": (np.array([1.0, -1.0, -1.0]), np.array([1.0, -1.0])),
    "left": (np.array([-1.0, 1.0, -1.0]), np.array([-1.0, -1.0])),
}


def _signs(finger: str):
    try:
        return _SIGNS[finger]
    except KeyError:
        raise ValueError(f"unknown finger {finger!r}; expected 'left' or 'right'") from None


def normal_component(markers: MarkerField, mode: NormalMode = "xy_norm") -> np.ndarray:
    """(N,) normal-force proxy per marker: displacement norm (2018) or diameter growth (later)."""
    return _normal(markers, markers.displacement, mode)


def _normal(markers: MarkerField, d: np.ndarray, mode: NormalMode) -> np.ndarray:
    if mode == "xy_norm":
        return np.hypot(d[:, 0], d[:, 1])
    if mode == "marker_size":
        return np.maximum(0.0, markers.size_change)
    raise ValueError(f"unknown normal_mode {mode!r}; expected 'xy_norm' or 'marker_size'")


def marker_forces(markers: MarkerField, finger: str, mode: NormalMode = "xy_norm") -> np.ndarray:
    """(N, 3) force vector per marker in the finger's convention."""
    fsign, _ = _signs(finger)
    d = markers.displacement
    out = np.empty((len(d), 3))
    out[:, 0] = d[:, 0]
    out[:, 1] = _normal(markers, d, mode)
    out[:, 2] = d[:, 1]
    out *= fsign
    return out


def marker_levers(markers: MarkerField, finger: str) -> np.ndarray:
    """(N, 2) normalised lever arm of each marker origin about the image centre."""
    _, psign = _signs(finger)
    w, h = markers.image_size
    div = (w + h) / 2.0
    r = (markers.origin - np.array([w / 2.0, h / 2.0])) / div
    return r * psign


def _average(values: np.ndarray, how: Averaging) -> np.ndarray:
    if how == "mean":
        return values.sum(axis=0) / len(values)  # what mean() does, without its overhead
    if how == "median":
        return np.median(values, axis=0)
    if how == "robust":
        # Mean of the samples inside the inter-quartile fence: rejects a few lost markers.
        q1, q3 = np.percentile(values, [25, 75], axis=0)
        fence = 1.5 * (q3 - q1)
        inside = (values >= q1 - fence) & (values <= q3 + fence)
        return np.where(inside, values, 0.0).sum(axis=0) / np.maximum(inside.sum(axis=0), 1)
    raise ValueError(f"unknown averaging {how!r}; expected 'mean', 'median' or 'robust'")


def _valid(markers: MarkerField) -> np.ndarray:
    """The valid mask; an empty mask means every marker is valid (signal-level states)."""
    if len(markers.valid) == 0:
        return np.ones(len(markers), bool)
    if len(markers.valid) != len(markers):
        raise ValueError(f"marker field has {len(markers)} markers but {len(markers.valid)} valid flags")
    return np.asarray(markers.valid, bool)


def wrench(
    markers: MarkerField,
    finger: str,
    mode: NormalMode = "xy_norm",
    averaging: Averaging = "mean",
    force_scale: np.ndarray | float = 1.0,
    torque_scale: np.ndarray | float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Averaged (force, torque) over the valid markers, times the calibration scales (1 = pixels);
    zeros when no marker is valid."""
    valid = _valid(markers)
    if not valid.any():
        return np.zeros(3), np.zeros(3)
    f = marker_forces(markers, finger, mode)
    p = marker_levers(markers, finger)
    if not valid.all():
        f, p = f[valid], p[valid]
    # [f, cross([p0, 0, p1], f)] per marker, averaged in one pass (small-array numpy calls
    # dominate the cost here, and this runs for every finger on every tick).
    fw = np.empty((len(f), 6))
    fw[:, :3] = f
    fw[:, 3] = -p[:, 1] * f[:, 1]
    fw[:, 4] = p[:, 1] * f[:, 0] - p[:, 0] * f[:, 2]
    fw[:, 5] = p[:, 0] * f[:, 1]
    mean = _average(fw, averaging)
    return mean[:3] * force_scale, mean[3:] * torque_scale
