"""Frame-to-frame marker tracking from the calibrated marker map.

Three trackers share the original's bookkeeping (predict from the last position, gate the jump and
the size change, count failures and reset a marker to its origin after more than `n_reset`):
  roi     the original `TrackKeyPoints2`: run the detector in a square ROI around each marker and
          take the nearest blob (two markers may claim the same blob);
  assign  detect once on the whole frame, then a one-to-one assignment (Hungarian) of blobs to
          markers, so two markers never claim the same blob;
  window  one compiled pass over all markers: a darkness-weighted centroid in a small window with
          a local threshold (robust to lighting), measured again where a marker moved off the window
          centre; markers that converge on one blob, and markers touched by something dark (the
          ring around them darker than at calibration), are flagged. Markers that moved further in
          one frame than the window reaches or the jump gate allows (a load taken up at once: a
          dense shear, largest inside the contact) are looked for again where their neighbours
          moved this frame, and gated against that place. Markers still lost (a jump larger than the
          window reaches, with their neighbours lost too) are re-acquired on the nearest marker-like
          blob within `reacquire` of the marker spacing that no trusted marker holds (`reacquire`).
An optional consistency check flags markers whose displacement leaves the local affine deformation
of their neighbours (a swap or a marker caught on a dark background feature), so that a firm shear
or twist, whose neighbours differ by a smooth gradient, passes. With `lost: neighbours` a lost
marker is searched where that deformation puts it, not reset to its origin, and one started again
takes the size its neighbours grew to.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from perception.config import ThresholdConfig, TrackerConfig
from perception.detect import Detector, marker_mask
from perception.tracking_kernels import measure_windows, near_trusted, predict_local

_INFEASIBLE = 1e9
RECENTRE = 3  # window tracker: re-measures of a marker found off its window centre
FOLLOW_ROUNDS = 3  # window tracker: rounds of looking for markers where their neighbours moved
SLACK = 0.15  # share of a marker's predicted displacement added to the consistency tolerance
GROWTH = 1.4  # window tracker: largest diameter over the calibrated one the dark-ring check follows


@dataclass(frozen=True)
class TrackResult:
    """Tracked markers of one frame (untracked markers: their last known or predicted position)."""

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


class LocalFit:
    """Each marker's displacement as its neighbours predict it from a local affine deformation.

    d(o) = t + A (o - o_i) is fitted to the trusted neighbours of marker i by least squares (the slope
    A pulled towards zero by `ridge`, in px per neighbour spacing) and t is the prediction: under
    shear, torsion or a press the neighbours' displacements differ by a smooth gradient that the fit
    follows, while a marker caught on a wrong blob leaves it. The fit of a fully trusted neighbourhood
    is a fixed linear combination, computed once."""

    def __init__(self, origin: np.ndarray, neighbours: np.ndarray, ridge: float = 0.5):
        n, k = neighbours.shape
        self.neighbours = np.ascontiguousarray(neighbours, np.int64)
        self._rows = np.arange(n)
        rel = origin[neighbours] - origin[:, None, :]  # (N, k, 2)
        scale = max(float(np.median(np.linalg.norm(rel, axis=2))), 1e-6) if k else 1.0
        self._x = np.concatenate([np.ones((n, k, 1)), rel / scale], axis=2)  # (N, k, 3)
        self._prior = np.diag([1e-9, ridge, ridge])
        m = np.einsum("nki,nkj->nij", self._x, self._x) + self._prior
        self._coef = np.linalg.solve(m, self._x.transpose(0, 2, 1))[:, 0, :].copy() if k else np.zeros((n, 0))

    def predict(self, displacement: np.ndarray, trusted: np.ndarray,
                rows: slice | np.ndarray = slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """((R, 2) displacement the trusted neighbours of the markers `rows` (default all) predict for
        them, (R,) their count): a caller that needs a few markers' predictions fits only those (each
        marker's fit is its own, so its values do not depend on which others are fitted)."""
        rows = self._rows[rows] if isinstance(rows, slice) else np.asarray(rows, np.int64)
        return predict_local(self._coef, self._x, self.neighbours, rows, np.ascontiguousarray(displacement, float),
                             np.ascontiguousarray(trusted, bool), self._prior)


def allowed_deviation(tolerance: float, predicted: np.ndarray) -> np.ndarray:
    """(R,) px a marker may lie off its neighbours' local affine fit: `tolerance`, plus `SLACK` of the
    displacement the fit predicts, since a firm press bends the gel more sharply than one affine map
    follows over a neighbourhood (a load peaked under the contact: 10-20 px next to 5-10 px), while a
    swap is a marker spacing off."""
    return tolerance + SLACK * np.sqrt((predicted * predicted).sum(axis=1))


def inconsistent(fit: LocalFit, displacement: np.ndarray, ok: np.ndarray, tolerance: float) -> np.ndarray:
    """(N,) markers whose displacement is further from what their valid neighbours' local deformation
    predicts (`LocalFit`) than `allowed_deviation`. Markers flagged are left out of their neighbours'
    fits in a second pass, so one wrong marker cannot flag good ones."""
    flagged = np.zeros(len(ok), bool)
    for _ in range(2):
        predicted, count = fit.predict(displacement, ok & ~flagged)
        dev = displacement - predicted
        limit = allowed_deviation(tolerance, predicted)
        again = ok & (count >= 2) & ((dev * dev).sum(axis=1) > limit * limit)  # two neighbours at least
        if not again.any() or np.array_equal(again, flagged):
            return again
        flagged = again
    return flagged


class MarkerTracker:
    """Shared state and bookkeeping; subclasses implement `_measure` for one frame."""

    # A marker started again takes the size its tracked neighbours grew to (with `lost: neighbours`);
    # off where the origin sizes are not the tracker's own measurements (calibration's candidates).
    regrow = True

    def __init__(self, cfg: TrackerConfig, origin: np.ndarray, origin_size: np.ndarray):
        if len(origin) == 0:
            raise ValueError("cannot track an empty marker map; calibrate on frames showing markers")
        self.cfg = cfg
        self.origin = np.asarray(origin, float).copy()
        self.origin_size = np.asarray(origin_size, float).copy()
        self._layout()
        self.reset()

    def _layout(self) -> None:
        """What follows from the marker layout (neighbourhoods; windows in the window tracker)."""
        self._fit = LocalFit(self.origin, neighbour_index(self.origin, self.cfg.neighbours))

    def add(self, origin: np.ndarray, size: np.ndarray, position: np.ndarray) -> None:
        """Append markers (rest origins (K, 2), diameters (K,)), now seen at `position` (K, 2): the
        existing markers keep their indices and their tracking state."""
        self.origin = np.concatenate([self.origin, origin])
        self.origin_size = np.concatenate([self.origin_size, size])
        self.position = np.concatenate([self.position, position])
        self.size = np.concatenate([self.size, size])
        self.failures = np.concatenate([self.failures, np.zeros(len(size), int)])
        self.ring = np.concatenate([self.ring, np.zeros(len(size))])
        self._layout()

    def reset(self) -> None:
        """Put every marker back at its calibrated origin with no failures."""
        self.position = self.origin.copy()
        self.size = self.origin_size.copy()
        self.failures = np.zeros(len(self.origin), int)
        self.ring = np.zeros(len(self.origin))  # dark share of the ring around each marker, last frame

    def step(self, bgr: np.ndarray, grey: np.ndarray) -> TrackResult:
        """Track all markers in one frame."""
        restarted = self.failures > self.cfg.n_reset
        if restarted.any():  # (selecting none costs some 10 us a frame)
            self.size[restarted] = self.origin_size[restarted]
        if self.cfg.lost == "neighbours":
            self._refind(restarted)  # before the failures are cleared: it reads them
        elif restarted.any():
            self.position[restarted] = self.origin[restarted]
        if restarted.any():
            self.failures[restarted] = 0
        xy, size, seen = self._measure(bgr, grey, self.position, self.size)
        ok = seen & self._gate(xy, size, self.position, self.size)
        if not ok.all():
            xy, size, ok = self._follow(grey, xy, size, seen, ok)
        if self.cfg.consistency > 0:
            ok &= ~inconsistent(self._fit, xy - self.origin, ok, self.cfg.consistency)
        self.position[ok] = xy[ok]
        self.size[ok] = size[ok]
        self.failures[ok] = 0
        self.failures[~ok] += 1
        return TrackResult(self.position.copy(), self.size.copy(), ok, restarted)

    def _gate(self, xy: np.ndarray, size: np.ndarray, expected: np.ndarray, last_size: np.ndarray) -> np.ndarray:
        """Measurements within `max_jump` of where each marker was expected and `max_size_change` of its size."""
        d = xy - expected
        return ((np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) < self.cfg.max_jump)
                & (np.abs(size - last_size) < self.cfg.max_size_change))

    def _follow(self, grey: np.ndarray, xy: np.ndarray, size: np.ndarray, seen: np.ndarray, ok: np.ndarray):
        """A second look at the markers that failed (the window tracker: where their neighbours moved)."""
        return xy, size, ok

    def _refind(self, restarted: np.ndarray) -> None:
        """Search for each lost marker where its tracked neighbours' local deformation puts it (the
        origin when fewer than two of them are tracked), not where it was last seen; a marker started
        again gets the size its tracked neighbours grew to (a firm press grows the markers beyond the
        area check of their rest size, so they could never be found again)."""
        lost = self.failures > 0
        if not lost.any():
            return
        rows = np.flatnonzero(lost)
        predicted, count = self._fit.predict(self.position - self.origin, ~lost, rows)
        fitted = count >= 2
        known = np.zeros_like(lost)
        known[rows[fitted]] = True
        self.position[known] = self.origin[known] + predicted[fitted]
        alone = lost & ~known & (self.failures > self.cfg.n_reset)
        self.position[alone] = self.origin[alone]
        grown = restarted & known
        if self.regrow and grown.any():
            nb = self._fit.neighbours[grown]
            tracked = ~lost[nb]
            growth = (self.size[nb] / self.origin_size[nb] * tracked).sum(axis=1) / tracked.sum(axis=1)
            self.size[grown] = self.origin_size[grown] * growth

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
    """Local search per marker (compiled): darkness-weighted centroid with a per-window threshold;
    markers that moved off their window centre are measured again around the first estimate."""

    def __init__(self, cfg: TrackerConfig, origin: np.ndarray, origin_size: np.ndarray,
                 ring_base: np.ndarray | None = None):
        # The ring's dark share at calibration (a dark edge behind the skin next to a marker): only
        # darkness beyond it flags the marker.
        self.ring_base = np.zeros(len(origin)) if ring_base is None else np.asarray(ring_base, float)
        super().__init__(cfg, origin, origin_size)

    def add(self, origin: np.ndarray, size: np.ndarray, position: np.ndarray, ring: np.ndarray | None = None) -> None:
        """Append markers as `MarkerTracker.add`, with their calibrated ring dark share (default 0)."""
        self.ring_base = np.concatenate([self.ring_base, np.zeros(len(size)) if ring is None else ring])
        super().add(origin, size, position)

    def measure_once(self, bgr: np.ndarray, grey: np.ndarray):
        """(positions, diameters, passed the checks, ring dark shares) of the markers measured once
        around their origins, with no history: vets candidate markers."""
        xy, size, ok = self._measure(bgr, grey, self.origin, self.origin_size)
        return xy, size, ok, self.ring.copy()

    def _layout(self) -> None:
        super()._layout()
        cfg = self.cfg
        radius = self.origin_size / 2.0  # markers differ in size (distance to the lens, foreshortening)
        self._half = int(cfg.window) if cfg.window > 0 else max(3, int(np.ceil(radius.max() + 3)))
        self._min_sep = 0.5 * min_spacing(self.origin)
        self._rows = np.arange(len(self.origin))
        self._probes = reacquire_probes(self.origin, self.origin_size, cfg.reacquire)
        self._reach = float(np.linalg.norm(self._probes, axis=1).max()) + 1.0 if len(self._probes) else 0.0
        off = np.arange(-self._half, self._half + 1, dtype=np.float32)
        # Centroid and size use only a disc 1 px larger than each marker, so that darker background
        # in the window corners or next to the marker does not pull the centroid or count as area.
        dist = np.hypot(off[:, None], off[None, :])[None]
        self._disc = dist <= (radius + 1.0)[:, None, None]

    def _ring_in(self, rows: np.ndarray, size: np.ndarray) -> np.ndarray:
        """Inner radius (px) of the ring checked for dark contamination around each of the markers
        `rows`, now `size` px across: 2 px wide around the window centre (within 1 px of the
        marker's), it starts past the marker's rim, its major semi-axis included (markers near the
        window rim are foreshortened to ellipses) and 1 px of centring slack. A marker grown under a
        press (up to `GROWTH` times its calibrated diameter) moves the ring out with its rim, so
        that its own edge does not count as something dark touching it."""
        base = self.origin_size[rows]
        grown = np.clip(size, base, GROWTH * base)
        return np.minimum(0.65 * grown + 1.0, self._half - 2.0)

    def _window(self, grey: np.ndarray, centre: np.ndarray, which: slice | np.ndarray,
                size: np.ndarray | None = None):
        """Centroid, diameter, contrast, dark-pixel count and the dark share of the ring just outside
        the marker in the window around each centre, for the markers `which` (compiled:
        `tracking_kernels.measure_windows`). In each window the background is the median of its
        border (robust to a bright or dark feature touching it) and the threshold half-way from it
        to the darkest pixel; the centroid is weighted by the depth below that threshold and, like
        the size (the covered share of each pixel between background and the marker's core), uses
        only the marker's disc (1 px larger than the marker)."""
        half, size = self._half, 2 * self._half + 1
        h, w = grey.shape
        if h < size or w < size:
            raise ValueError(f"image {w}x{h} is smaller than one tracking window ({size} px)")
        rows = self._rows if isinstance(which, slice) else np.asarray(which, np.int64)
        ring_in = self._ring_in(rows, self.origin_size[rows] if size is None else np.asarray(size, float))
        return measure_windows(grey, np.asarray(centre, float), rows, self._disc, ring_in, half)

    def _measure(self, bgr, grey, pred_xy, pred_size):
        xy, size, ok, self.ring = self._look(grey, pred_xy, slice(None), pred_size, 1)
        return xy, size, ok & ~self._clash(xy, ok)

    def _look(self, grey: np.ndarray, centre: np.ndarray, which: slice | np.ndarray, pred_size: np.ndarray,
              recentre: int):
        """(positions, diameters, passed the checks, ring dark shares) of the markers `which` measured
        in windows around `centre`; a marker found off its window centre (it may be cut by the window
        edge) is measured again where it was found, up to `recentre` times, so that the window follows
        it."""
        xy, size, contrast, count, ring_dark = self._window(grey, centre, which, pred_size)
        moved = np.flatnonzero(np.abs(xy - np.rint(centre)).max(axis=1) > 1.0)
        for _ in range(recentre):
            if not len(moved):
                break
            start = xy[moved]
            again = self._window(grey, start, moved if isinstance(which, slice) else which[moved], pred_size[moved])
            for full, part in zip((xy, size, contrast, count, ring_dark), again):
                full[moved] = part
            moved = moved[np.abs(xy[moved] - np.rint(start)).max(axis=1) > 1.0]
        ratio = count / (np.pi / 4.0 * pred_size * pred_size)  # dark pixels over the expected marker area
        lo, hi = self.cfg.area_range
        ok = (contrast >= self.cfg.min_contrast) & (ratio >= lo) & (ratio <= hi)
        # Something dark came to touch the marker: its measurement may be biased, so it is not trusted.
        ok &= ring_dark <= self.ring_base[which] + self.cfg.max_ring_dark
        return xy, size, ok, ring_dark

    def _clash(self, xy: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """Markers within half the calibrated spacing of a trusted one: two markers on one blob,
        neither is trusted."""
        if not self._min_sep < np.inf or ok.sum() <= 1:
            return np.zeros(len(xy), bool)
        return near_trusted(np.asarray(xy, float), ok, self._min_sep)

    def _follow(self, grey, xy, size, seen, ok):
        xy, size, ok = self._follow_neighbours(grey, xy, size, seen, ok)
        if len(self._probes) and not ok.all():
            xy, size, ok = self._reacquire(grey, xy, size, ok)
        return xy, size, ok

    def _reacquire(self, grey: np.ndarray, xy: np.ndarray, size: np.ndarray, ok: np.ndarray):
        """Markers still lost are looked for on a grid of window centres (`_probes`) around where
        they are expected (their trusted neighbours' motion this frame where two or more are
        trusted, else their last place); each probe's window follows the blob it finds (`RECENTRE`).
        A blob counts when it passes the window checks, keeps the marker's size within
        `max_size_change` and lies half a spacing clear of every trusted marker (not a neighbour's
        blob); each lost marker takes the nearest, and two that take one blob are both left lost (as
        `_clash`); one is kept only where two or more of its neighbours (trusted, or found again with
        it) moved alike (within the consistency tolerance of their local deformation). So a skin
        that jumped further in one frame than the window reaches (a knock, a slip: every marker in
        view, none where it was) is followed again at once; a marker out of view finds nothing."""
        lost = np.flatnonzero(~ok)
        predicted, count = self._fit.predict(xy - self.position, ok, lost)
        expected = self.position[lost] + np.where((count >= 2)[:, None], predicted, 0.0)
        k = len(self._probes)
        rows = np.repeat(lost, k)
        last_size = np.repeat(self.size[lost], k)
        centre = (expected[:, None, :] + self._probes[None]).reshape(-1, 2)
        fxy, fsize, fok, _ = self._look(grey, centre, rows, last_size, RECENTRE)
        fok &= np.abs(fsize - last_size) < self.cfg.max_size_change
        dist = np.linalg.norm(fxy - np.repeat(expected, k, axis=0), axis=1)
        fok &= dist <= self._reach
        if not fok.any():
            return xy, size, ok
        fok[fok] &= ~near_trusted(np.concatenate([xy[ok], fxy[fok]]),
                                  np.r_[np.ones(int(ok.sum()), bool), np.zeros(int(fok.sum()), bool)],
                                  self._min_sep)[int(ok.sum()):]
        dist = np.where(fok, dist, np.inf).reshape(len(lost), k)
        best = dist.argmin(axis=1)
        has = np.isfinite(dist[np.arange(len(lost)), best])
        if not has.any():
            return xy, size, ok
        pick = np.flatnonzero(has) * k + best[has]
        new = lost[has]
        clash = near_trusted(fxy[pick], np.ones(len(pick), bool), self._min_sep)
        pick, new = pick[~clash], new[~clash]
        xy, size, found = xy.copy(), size.copy(), ok.copy()
        xy[new], size[new], found[new] = fxy[pick], fsize[pick], True
        # A blob is that marker's only where the markers around it (trusted, or found again with it)
        # moved alike: two of them at least, their local deformation putting it within the consistency
        # tolerance (a dark spot of an object, or a marker cut by the image's rim, is not).
        tolerance = self.cfg.consistency if self.cfg.consistency > 0 else self.cfg.max_jump
        for _ in range(2):
            predicted, count = self._fit.predict(xy - self.origin, found, new)
            dev = xy[new] - self.origin[new] - predicted
            limit = allowed_deviation(tolerance, predicted)
            keep = (count >= 2) & ((dev * dev).sum(axis=1) <= limit * limit)
            if keep.all():
                break
            found[new[~keep]] = False
            new = new[keep]
        return xy, size, found

    def _follow_neighbours(self, grey, xy, size, seen, ok):
        """Markers that moved further in a frame than the window reaches or the jump gate allows
        (a sudden dense shear: the inner markers move most) are looked for again where the frame's
        motion of their neighbours (those measured, `seen`) puts them, the window following each
        marker up to `RECENTRE` times, and gated against that place, not their last one. Rounds
        reach inwards from the markers found. Only where the neighbourhood moved more than 1 px in
        the frame; markers trusted at the first look keep their measurement."""
        again = ~ok
        motion = np.abs(xy - self.position)[ok | seen]
        if not len(motion) or motion.max() <= 1.0:  # nothing measured moved more than 1 px: still skin
            return xy, size, ok
        for _ in range(FOLLOW_ROUNDS):
            rows = np.flatnonzero(again)
            predicted, count = self._fit.predict(xy - self.position, ok | seen, rows)
            pick = (count >= 2) & (np.abs(predicted).max(axis=1) > 1.0)
            wide = rows[pick]
            if not len(wide):
                break
            expected = self.position[wide] + predicted[pick]
            fxy, fsize, fok, fring = self._look(grey, expected, wide, self.size[wide], RECENTRE)
            fok &= self._gate(fxy, fsize, expected, self.size[wide])
            xy, size, seen = xy.copy(), size.copy(), seen.copy()
            xy[wide], size[wide], seen[wide], self.ring[wide] = fxy, fsize, fok, fring
            found = ok.copy()
            found[wide] = fok
            found &= ~self._clash(xy, found)
            again[wide] = ~found[wide]
            if np.array_equal(found, ok):
                break
            ok = found
        return xy, size, ok


def reacquire_probes(origin: np.ndarray, origin_size: np.ndarray, reach: float) -> np.ndarray:
    """(K, 2) offsets of the window centres searched around a lost marker: a square grid, one marker
    radius apart (a window finds a marker whose centre is within its disc), inside `reach` of the median
    calibrated marker spacing; none when `reach` is 0 or there are fewer than two markers."""
    if reach <= 0.0 or len(origin) < 2:
        return np.zeros((0, 2))
    d = np.linalg.norm(origin[:, None, :] - origin[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    radius = reach * float(np.median(d.min(axis=1)))
    step = max(2.0, 0.5 * float(np.median(origin_size)))
    ticks = np.arange(-np.floor(radius / step), np.floor(radius / step) + 1) * step
    grid = np.stack(np.meshgrid(ticks, ticks), axis=-1).reshape(-1, 2)
    grid = grid[np.linalg.norm(grid, axis=1) <= radius]
    return grid[np.argsort(np.linalg.norm(grid, axis=1), kind="stable")]


def make_tracker(cfg: TrackerConfig, threshold: ThresholdConfig, detector: Detector,
                 origin: np.ndarray, origin_size: np.ndarray, ring_base: np.ndarray | None = None) -> MarkerTracker:
    """The tracker named by `cfg.kind`, started at the calibrated origins (`ring_base`: the window
    tracker's calibrated dark share of each marker's ring)."""
    if cfg.kind == "roi":
        return RoiTracker(cfg, threshold, detector, origin, origin_size)
    if cfg.kind == "assign":
        return AssignTracker(cfg, threshold, detector, origin, origin_size)
    return WindowTracker(cfg, origin, origin_size, ring_base)
