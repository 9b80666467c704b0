"""Frame-to-frame marker tracking from the calibrated marker map.

Three trackers share the original's bookkeeping (predict from the last position, gate the jump and
the size change, count failures and reset a marker to its origin after more than `n_reset`):
  roi     the original `TrackKeyPoints2`: run the detector in a square ROI around each marker and
          take the nearest blob (two markers may claim the same blob);
  assign  detect once on the whole frame, then a one-to-one assignment (Hungarian) of blobs to
          markers, so two markers never claim the same blob;
  window  vectorised over all markers: a darkness-weighted centroid in a small window with a local
          threshold (robust to lighting), measured again where a marker moved off the window
          centre; markers that converge on one blob are flagged.
An optional neighbour consistency check flags markers whose displacement leaves that of their
neighbours (a swap or a marker caught on a dark background feature).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.optimize import linear_sum_assignment

from perception.config import ThresholdConfig, TrackerConfig
from perception.detect import Detector, marker_mask

_INFEASIBLE = 1e9


@dataclass(frozen=True)
class TrackResult:
    """Tracked markers of one frame (positions of untracked markers are their last known ones)."""

    position: np.ndarray  # (N, 2) px
    size: np.ndarray  # (N,) px diameter
    valid: np.ndarray  # (N,) bool, measured this frame and passed every gate
    restarted: np.ndarray  # (N,) bool, reset to the origin this frame after repeated failures


def neighbour_index(origin: np.ndarray, k: int) -> np.ndarray:
    """(N, k) indices of each marker's k nearest calibrated neighbours (fewer markers: all others)."""
    n = len(origin)
    k = max(0, min(k, n - 1))
    d = np.linalg.norm(origin[:, None, :] - origin[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    return np.argsort(d, axis=1)[:, :k]


def min_spacing(origin: np.ndarray) -> float:
    """Smallest distance between two calibrated markers (inf for fewer than two)."""
    if len(origin) < 2:
        return float("inf")
    d = np.linalg.norm(origin[:, None, :] - origin[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    return float(d.min())


def inconsistent(displacement: np.ndarray, ok: np.ndarray, neighbours: np.ndarray,
                 tolerance: float) -> np.ndarray:
    """(N,) markers whose displacement differs from the median of their valid neighbours by > tolerance."""
    k = neighbours.shape[1]
    if k == 0:
        return np.zeros(len(ok), bool)
    nok = ok[neighbours]  # (N, k)
    count = nok.sum(axis=1)
    # Median over the valid neighbours only: invalid ones sort to the end as +inf.
    nd = np.where(nok[:, :, None], displacement[neighbours], np.inf)
    nd.sort(axis=1)
    lo = np.clip((count - 1) // 2, 0, k - 1)[:, None, None]
    hi = np.clip(count // 2, 0, k - 1)[:, None, None]
    med = 0.5 * (np.take_along_axis(nd, lo, 1) + np.take_along_axis(nd, hi, 1))[:, 0, :]
    enough = count >= 2  # cannot judge a marker from fewer than two neighbours
    with np.errstate(invalid="ignore"):
        dev = np.linalg.norm(displacement - med, axis=1)
    return ok & enough & (dev > tolerance)


class MarkerTracker:
    """Shared state and bookkeeping; subclasses implement `_measure` for one frame."""

    def __init__(self, cfg: TrackerConfig, origin: np.ndarray, origin_size: np.ndarray):
        if len(origin) == 0:
            raise ValueError("cannot track an empty marker map; calibrate on frames showing markers")
        self.cfg = cfg
        self.origin = np.asarray(origin, float).copy()
        self.origin_size = np.asarray(origin_size, float).copy()
        self._neighbours = neighbour_index(self.origin, cfg.neighbours)
        self.reset()

    def reset(self) -> None:
        """Put every marker back at its calibrated origin with no failures."""
        self.position = self.origin.copy()
        self.size = self.origin_size.copy()
        self.failures = np.zeros(len(self.origin), int)

    def step(self, bgr: np.ndarray, grey: np.ndarray) -> TrackResult:
        """Track all markers in one frame."""
        restarted = self.failures > self.cfg.n_reset
        self.position[restarted] = self.origin[restarted]
        self.size[restarted] = self.origin_size[restarted]
        self.failures[restarted] = 0
        xy, size, ok = self._measure(bgr, grey, self.position, self.size)
        ok &= np.linalg.norm(xy - self.position, axis=1) < self.cfg.max_jump
        ok &= np.abs(size - self.size) < self.cfg.max_size_change
        if self.cfg.consistency > 0:
            ok &= ~inconsistent(xy - self.origin, ok, self._neighbours, self.cfg.consistency)
        self.position[ok] = xy[ok]
        self.size[ok] = size[ok]
        self.failures[ok] = 0
        self.failures[~ok] += 1
        return TrackResult(self.position.copy(), self.size.copy(), ok, restarted)

    def _measure(self, bgr, grey, pred_xy, pred_size):
        raise NotImplementedError


class RoiTracker(MarkerTracker):
    """The original per-marker ROI search: detector in a square around the prediction, nearest blob."""

    def __init__(self, cfg: TrackerConfig, threshold: ThresholdConfig, detector: Detector,
                 origin: np.ndarray, origin_size: np.ndarray):
        super().__init__(cfg, origin, origin_size)
        self.threshold, self.detector = threshold, detector

    def _measure(self, bgr, grey, pred_xy, pred_size):
        prep = marker_mask(bgr, grey, self.threshold)
        h, w = grey.shape
        half = self.cfg.search / 2.0
        lo, hi = self.cfg.nonzero_range
        xy, size = pred_xy.copy(), pred_size.copy()
        ok = np.zeros(len(pred_xy), bool)
        for i, ((px, py), s0) in enumerate(zip(pred_xy, self.origin_size)):
            x0, y0 = max(0, int(px - half)), max(0, int(py - half))
            x1, y1 = min(w, int(px + half) + 1), min(h, int(py + half) + 1)
            if x1 - x0 < 3 or y1 - y0 < 3:
                continue
            # Mask fill relative to the marker's bounding square (a lone disc gives pi/4).
            fill = np.count_nonzero(prep.mask[y0:y1, x0:x1]) / max(s0 * s0, 1.0)
            if not lo <= fill <= hi:
                continue
            blobs = self.detector.detect(prep, (x0, y0, x1, y1))
            if len(blobs) == 0:
                continue
            j = int(np.argmin(np.linalg.norm(blobs.xy - (px, py), axis=1)))
            xy[i], size[i], ok[i] = blobs.xy[j], blobs.size[j], True
        return xy, size, ok


class AssignTracker(MarkerTracker):
    """Whole-frame detection and a one-to-one, gated assignment of blobs to markers."""

    def __init__(self, cfg: TrackerConfig, threshold: ThresholdConfig, detector: Detector,
                 origin: np.ndarray, origin_size: np.ndarray):
        super().__init__(cfg, origin, origin_size)
        self.threshold, self.detector = threshold, detector

    def _measure(self, bgr, grey, pred_xy, pred_size):
        blobs = self.detector.detect(marker_mask(bgr, grey, self.threshold))
        xy, size = pred_xy.copy(), pred_size.copy()
        ok = np.zeros(len(pred_xy), bool)
        if len(blobs) == 0:
            return xy, size, ok
        dist = np.linalg.norm(pred_xy[:, None, :] - blobs.xy[None, :, :], axis=2)
        feasible = (dist < self.cfg.max_jump) & (
            np.abs(pred_size[:, None] - blobs.size[None, :]) < self.cfg.max_size_change)
        rows = np.flatnonzero(feasible.any(axis=1))
        cols = np.flatnonzero(feasible.any(axis=0))
        if len(rows) == 0:
            return xy, size, ok
        cost = np.where(feasible[np.ix_(rows, cols)], dist[np.ix_(rows, cols)], _INFEASIBLE)
        r, c = linear_sum_assignment(cost)
        good = cost[r, c] < _INFEASIBLE
        mi, bi = rows[r[good]], cols[c[good]]
        xy[mi], size[mi], ok[mi] = blobs.xy[bi], blobs.size[bi], True
        return xy, size, ok


class WindowTracker(MarkerTracker):
    """Vectorised local search: darkness-weighted centroid with a per-window threshold; markers that
    moved off their window centre are measured again around the first estimate."""

    def __init__(self, cfg: TrackerConfig, origin: np.ndarray, origin_size: np.ndarray):
        super().__init__(cfg, origin, origin_size)
        radius = float(np.median(origin_size)) / 2.0
        self._half = int(cfg.window) if cfg.window > 0 else max(3, int(np.ceil(radius + 3)))
        self._area0 = np.pi * (self.origin_size / 2.0) ** 2
        self._min_sep = 0.5 * min_spacing(self.origin)
        self._off = np.arange(-self._half, self._half + 1, dtype=np.float32)
        # Centroid and size use only a disc a little larger than a marker, so that darker background
        # in the window corners does not pull the centroid or count as marker area.
        self._disc = np.hypot(self._off[:, None], self._off[None, :]) <= radius + 2.0

    def _window(self, grey: np.ndarray, centre: np.ndarray):
        """Centroid, diameter, contrast and dark-pixel count in the window around each centre."""
        half, size = self._half, 2 * self._half + 1
        h, w = grey.shape
        if h < size or w < size:
            raise ValueError(f"image {w}x{h} is smaller than one tracking window ({size} px)")
        cx = np.clip(np.rint(centre[:, 0]).astype(int), half, w - 1 - half)
        cy = np.clip(np.rint(centre[:, 1]).astype(int), half, h - 1 - half)
        p = sliding_window_view(grey, (size, size))[cy - half, cx - half]  # (N, P, P) float32
        ring = np.concatenate([p[:, 0, :], p[:, -1, :], p[:, 1:-1, 0], p[:, 1:-1, -1]], axis=1)
        bg = np.median(ring, axis=1)  # robust to a bright or dark feature touching the window
        dark = p.min(axis=(1, 2))
        below = np.maximum(0.5 * (bg + dark)[:, None, None] - p, 0) * self._disc  # depth below half-way
        inside = below > 0
        count = inside.sum(axis=(1, 2))
        core = (p * inside).sum(axis=(1, 2)) / np.maximum(count, 1)
        cover = (bg[:, None, None] - p) / np.maximum(bg - core, 1.0)[:, None, None]
        area = np.where((cover > 0.15) & self._disc, np.minimum(cover, 1.0), 0).sum(axis=(1, 2))
        total = below.sum(axis=(1, 2)) + np.float32(1e-6)
        xy = np.column_stack([cx + (below.sum(axis=1) @ self._off) / total,
                              cy + (below.sum(axis=2) @ self._off) / total])
        return xy, 2.0 * np.sqrt(area / np.pi), bg - dark, count

    def _measure(self, bgr, grey, pred_xy, pred_size):
        g = grey.astype(np.float32)
        xy, size, contrast, count = self._window(g, pred_xy)
        moved = np.abs(xy - np.rint(pred_xy)).max(axis=1) > 1.0
        if moved.any():  # the marker may be cut by the window edge: measure it again where it is
            again = self._window(g, xy[moved])
            for full, part in zip((xy, size, contrast, count), again):
                full[moved] = part
        ratio = count / self._area0
        lo, hi = self.cfg.area_range
        ok = (contrast >= self.cfg.min_contrast) & (ratio >= lo) & (ratio <= hi)
        if self._min_sep < np.inf and ok.sum() > 1:
            d = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2)
            np.fill_diagonal(d, np.inf)
            clash = (d < self._min_sep) & ok[None, :]
            ok &= ~clash.any(axis=1)  # two markers on one blob: neither is trusted
        return xy, size, ok


def make_tracker(cfg: TrackerConfig, threshold: ThresholdConfig, detector: Detector,
                 origin: np.ndarray, origin_size: np.ndarray) -> MarkerTracker:
    """The tracker named by `cfg.kind`, started at the calibrated origins."""
    if cfg.kind == "roi":
        return RoiTracker(cfg, threshold, detector, origin, origin_size)
    if cfg.kind == "assign":
        return AssignTracker(cfg, threshold, detector, origin, origin_size)
    return WindowTracker(cfg, origin, origin_size)
