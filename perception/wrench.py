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


def _normal(markers: MarkerField, d: np.ndarray, mode: NormalMode, out: np.ndarray | None = None) -> np.ndarray:
    if mode == "xy_norm":
        return np.hypot(d[:, 0], d[:, 1], out=out)
    if mode == "marker_size":
        return np.maximum(0.0, markers.size_change, out=out)
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
        total = np.add.reduce(values, axis=0)  # what mean() does, without its overhead
        total /= len(values)
        return total
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
    return np.ascontiguousarray(markers.valid, bool)


_TERMS = np.array([0, 2, 1, 2, 0, 2, 1])  # columns of [dx, dy, normal] in each term of `wrench_terms`
_CACHE_SIZE = 16  # marker maps whose terms are kept (two fingers, a few maps over a run)
_cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}


def wrench_terms(markers: MarkerField, finger: str) -> np.ndarray:
    """(N, 7) factors of [dx, normal, dy, normal, dx, normal, dy] per marker: the three force
    components and the torque terms -p1 f1, p1 f0, p0 f1, -p0 f2 (f = signed force, p = lever),
    with the signs folded in (exact: they are +-1). Kept per marker origin array and finger: an
    origin array is never changed in place (a marker map that grows makes a new one)."""
    origin = markers.origin
    key = (id(origin), finger, markers.image_size)
    hit = _cache.get(key)
    if hit is not None and hit[0] is origin:
        return hit[1]
    fsign, _ = _signs(finger)
    p = marker_levers(markers, finger)
    terms = np.empty((len(origin), 7))
    terms[:, :3] = fsign
    terms[:, 3] = -p[:, 1] * fsign[1]
    terms[:, 4] = p[:, 1] * fsign[0]
    terms[:, 5] = p[:, 0] * fsign[1]
    terms[:, 6] = -p[:, 0] * fsign[2]
    terms.flags.writeable = False  # shared by every call on this marker map
    if len(_cache) >= _CACHE_SIZE:
        _cache.clear()
    _cache[key] = (origin, terms)
    return terms


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
    terms = wrench_terms(markers, finger)
    if averaging == "mean" and mode == "xy_norm":
        from perception.wrench_kernel import mean_wrench

        force, torque = mean_wrench(np.ascontiguousarray(markers.position, float),
                                    np.ascontiguousarray(markers.origin, float), terms, valid)
        return _scaled(force, force_scale), _scaled(torque, torque_scale)
    count = int(np.count_nonzero(valid))
    if count == 0:
        return np.zeros(3), np.zeros(3)
    # [f, cross([p0, 0, p1], f)] per marker as seven products of [dx, dy, normal] with the cached
    # factors; the same arithmetic per marker as marker_forces/marker_levers.
    d = np.empty((len(valid), 3))
    np.subtract(markers.position, markers.origin, out=d[:, :2])
    _normal(markers, d[:, :2], mode, out=d[:, 2])
    fw = d.take(_TERMS, axis=1)  # C order, so the average sums each column marker by marker as before
    fw *= terms
    if count < len(valid):
        fw = fw[valid]
    fw[:, 4] += fw[:, 6]
    mean = _average(fw[:, :6], averaging)
    return _scaled(mean[:3], force_scale), _scaled(mean[3:], torque_scale)


def warm_up() -> None:
    """Load the compiled wrench now (compiled at first use on a machine and cached; loading it costs
    ~0.5 s in a fresh process): sensors call this when they are set up, so that their first tick does
    not pay for it, on a real cell as in simulation."""
    origin = np.zeros((1, 2))
    wrench(MarkerField(origin, origin.copy(), np.ones(1), np.ones(1), np.ones(1, bool)), "left")


def _scaled(values: np.ndarray, scale: np.ndarray | float) -> np.ndarray:
    """`values * scale`, skipping the (exact, but not free) product with the default scale 1."""
    return values if isinstance(scale, float) and scale == 1.0 else values * scale
