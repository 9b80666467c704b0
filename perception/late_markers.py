"""Markers missed at calibration (covered by an object, merged with a dark edge), added once they are
plainly visible at one place on the skin.

Every `late.every` frames the lattice sites that no marker holds (one step on from each marker along
each row through it, `calibration.lattice_steps`) are measured with the window tracker, and what
they find is measured again centred on it. A candidate must look like a calibrated marker (the
window tracker's contrast, area and dark-ring checks with a clean ring, the calibration's size band
and core darkness, and a round outline), sit in a hole of the lattice (about one marker spacing from
the nearest marker, with tracked markers around it), lie where the skin is at rest (so its rest
position is measured, not extrapolated), and keep that rest position over `late.confirm` searches
in a row. A dark object moving behind the skin, an object edge or a texture square does not pass
all of this. Confirmed markers are appended to the marker map: existing indices never change, and
a hole deep in a covered patch is reached once the markers around it are added.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numpy as np

from perception.calibration import MarkerMap, lattice_steps
from perception.config import FingerVisionConfig
from perception.marker_tracking import WindowTracker
from perception.state import MarkerField

MIN_ROUNDNESS = 0.76  # blob area over its enclosing circle's: a marker 0.78-0.9 measured, a square 0.64-0.76
MAX_RING = 0.05  # dark share of the ring around a candidate: an uncovered marker has a clean ring
HOLE = (0.75, 1.35)  # nearest calibrated marker, in marker spacings, of a lattice hole
MIN_AROUND = 3  # tracked markers within 1.6 spacings needed to place a candidate on the skin
AT_REST = 1.0  # px: the largest displacement of those markers for the skin there to count as at rest
RIDGE = 0.5  # slope prior of the local affine fit, as in the tracker's consistency check


@dataclass
class _Candidate:
    """A blob seen at one rest position in consecutive searches."""

    rest: np.ndarray  # (2,) px, rest position when first seen
    size: float  # px diameter when first seen
    xy: np.ndarray  # (2,) px, where it was last seen
    rests: list[np.ndarray]
    sizes: list[float]
    rings: list[float]


@dataclass(frozen=True)
class NewMarkers:
    """Markers confirmed by one search: rest origins (K, 2), diameters (K,), where they are now
    (K, 2) and their ring's dark share (K,)."""

    origin: np.ndarray
    size: np.ndarray
    position: np.ndarray
    ring: np.ndarray


def local_displacement(points: np.ndarray, markers: MarkerField,
                       radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """((K, 2) displacement the tracked markers within `radius` px of each point predict for it by a
    local affine fit, (K,) how many there were, (K,) the largest of their displacements in px)."""
    valid = np.flatnonzero(markers.valid)
    out, count, largest = np.zeros((len(points), 2)), np.zeros(len(points), int), np.full(len(points), np.inf)
    if len(valid) == 0:
        return out, count, largest
    pos, disp = markers.position[valid], markers.displacement[valid]
    for k, p in enumerate(points):
        near = np.linalg.norm(pos - p, axis=1) < radius
        count[k] = int(near.sum())
        if count[k] < 3:
            continue
        largest[k] = float(np.linalg.norm(disp[near], axis=1).max())
        rel = (markers.origin[valid][near] - p) / radius
        x = np.column_stack([np.ones(count[k]), rel])
        m = x.T @ x + np.diag([1e-9, RIDGE, RIDGE])
        out[k] = np.linalg.solve(m, x.T @ disp[near])[0]
    return out, count, largest


def roundness(grey: np.ndarray, xy: np.ndarray, half: int) -> np.ndarray:
    """(K,) area of the dark blob at each point (darker than half-way between the window's border
    median and its darkest pixel) over the area of its smallest enclosing circle."""
    h, w = grey.shape
    out = np.zeros(len(xy))
    for k, (x, y) in enumerate(np.rint(xy).astype(int)):
        x0, y0 = max(0, x - half), max(0, y - half)
        patch = grey[y0:min(h, y + half + 1), x0:min(w, x + half + 1)].astype(np.float32)
        border = np.concatenate([patch[0], patch[-1], patch[1:-1, 0], patch[1:-1, -1]])
        dark = (patch < 0.5 * (np.median(border) + patch.min())).view(np.uint8)
        _, labels = cv2.connectedComponents(dark, connectivity=8)
        label = labels[min(y - y0, patch.shape[0] - 1), min(x - x0, patch.shape[1] - 1)]
        if label == 0:
            continue
        pts = np.column_stack(np.nonzero(labels == label)[::-1]).astype(np.float32)
        _, r = cv2.minEnclosingCircle(pts)
        out[k] = len(pts) / (np.pi * (r + 0.5) ** 2)  # pixel centres: the rim lies half a pixel out
    return out


class LateMarkers:
    """Searches frames for markers missing from the map; `search` returns those it confirms."""

    def __init__(self, config: FingerVisionConfig, marker_map: MarkerMap):
        self.config = config
        self._probe: WindowTracker | None = None
        self._sites_for = -1  # the map size the sites were found for
        self._typical = float(np.median(marker_map.size))
        self._kernel = np.ones((2 * int(np.ceil(self._typical / 2 + 3)) + 1,) * 2, np.uint8)  # a window's span
        self._margin = int(np.ceil(self._typical / 2 + 4))  # px: sites this close to the image's rim are left out
        d = np.linalg.norm(marker_map.origin[:, None] - marker_map.origin[None], axis=2)
        np.fill_diagonal(d, np.inf)
        self._spacing = float(np.median(d.min(axis=1))) if len(d) > 1 else np.inf
        self._frame = 0
        self._candidates: list[_Candidate] = []

    def search(self, bgr: np.ndarray, grey: np.ndarray, markers: MarkerField) -> NewMarkers | None:
        """Check this frame (every `late.every` frames); the markers confirmed now, or None."""
        self._frame += 1
        if self._frame % self.config.late.every or not np.isfinite(self._spacing):
            return None
        found = self._marker_like(bgr, grey, markers)
        confirmed = self._follow(*found)
        if not confirmed:
            return None
        return NewMarkers(np.array([np.mean(c.rests, axis=0) for c in confirmed]),
                          np.array([np.mean(c.sizes) for c in confirmed]), np.array([c.xy for c in confirmed]),
                          np.array([np.median(c.rings) for c in confirmed]))

    def _sites(self, origin: np.ndarray, shape: tuple[int, int]) -> WindowTracker | None:
        """A probe (window tracker) at the lattice sites no marker holds yet: one step on from each
        marker along each row through it (`calibration.lattice_steps`), inside the image and the lattice,
        one per hole. Cached until the map grows."""
        if self._sites_for == len(origin):
            return self._probe
        site = lattice_steps(origin)[0].reshape(-1, 2)
        (h, w), m = shape, self._margin
        keep = (site[:, 0] >= m) & (site[:, 0] < w - m) & (site[:, 1] >= m) & (site[:, 1] < h - m)
        site = site[keep]
        d = np.linalg.norm(site[:, None] - origin[None], axis=2)
        # In a hole (or at the rim of a covered patch), not one step out of the lattice's edge.
        site = site[(d.min(axis=1) >= HOLE[0] * self._spacing) & ((d < 1.6 * self._spacing).sum(axis=1) >= MIN_AROUND)]
        groups: list[list[np.ndarray]] = []  # one site per hole: the mean of the steps that reach it
        for p in site:
            group = next((g for g in groups if np.linalg.norm(p - np.mean(g, axis=0)) < 0.5 * self._spacing), None)
            if group is None:
                groups.append([p])
            else:
                group.append(p)
        one = np.array([np.mean(g, axis=0) for g in groups]).reshape(-1, 2)
        # The ring is judged on the second, centred measurement (`_marker_like`).
        loose = dataclasses.replace(self.config.tracker, max_ring_dark=1.0)
        self._probe = WindowTracker(loose, one, np.full(len(one), self._typical)) if len(one) else None
        self._sites_for = len(origin)
        return self._probe

    def _marker_like(self, bgr, grey, markers: MarkerField):
        """(rest positions, positions, sizes, ring shares) of the blobs at lattice holes that pass every
        check this frame."""
        none = (np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0))
        if markers.valid.sum() < MIN_AROUND:
            return none
        probe = self._sites(markers.origin, grey.shape)
        if probe is None:
            return none
        # Markers are black ink: the sites are measured when one has something as dark as a marker core.
        ink = 0.5 * (np.median(_core(grey, markers.position[markers.valid])) + float(np.median(grey[::4, ::4])))
        x, y = np.rint(probe.origin).astype(int).T
        if not (cv2.erode(grey, self._kernel)[y, x] <= ink).any():
            return none
        xy, size, ok, ring = probe.measure_once(bgr, grey)
        ok &= (size > 0.5 * self._typical) & (size < 1.6 * self._typical)
        ok &= np.linalg.norm(xy[:, None] - markers.position[None], axis=2).min(axis=1) >= 0.6 * self._spacing
        if not ok.any():
            return none
        # Measured again centred on what the sites found (a site is up to a few px off its marker), with
        # the window tracker's own checks (contrast, dark area, ring) and a clean ring required.
        cal = self.config.calibration
        strict = dataclasses.replace(self.config.tracker, max_ring_dark=min(cal.max_ring, MAX_RING))
        xy, size, ok, ring = WindowTracker(strict, xy[ok], size[ok]).measure_once(bgr, grey)
        xy, size, ring = xy[ok], size[ok], ring[ok]
        # Only where the skin is at rest: there the rest position is measured, not extrapolated.
        shift, around, moved = local_displacement(xy, markers, 1.6 * self._spacing)
        rest = xy - shift
        nearest = np.linalg.norm(rest[:, None] - markers.origin[None], axis=2).min(axis=1) / self._spacing
        ok = (around >= MIN_AROUND) & (moved <= AT_REST) & (nearest >= HOLE[0]) & (nearest <= HOLE[1])
        ok &= roundness(grey, xy, self._margin) >= MIN_ROUNDNESS
        ok &= _core(grey, xy) <= ink
        return rest[ok], xy[ok], size[ok], ring[ok]

    def _follow(self, rest, xy, size, ring) -> list[_Candidate]:
        """Match this search's blobs to the candidates at their rest positions; those seen in
        `late.confirm` searches in a row are confirmed (and no longer followed)."""
        late, cal = self.config.late, self.config.calibration
        kept, confirmed, used = [], [], np.zeros(len(rest), bool)
        for cand in self._candidates:
            if not len(rest):
                break
            dist = np.linalg.norm(rest - cand.rest, axis=1)
            dist[used] = np.inf
            j = int(dist.argmin())
            if dist[j] > late.max_drift or abs(size[j] - cand.size) > cal.max_size_drift:
                continue  # not seen in place this time: start again
            used[j] = True
            cand.xy = xy[j]
            cand.rests.append(rest[j])
            cand.sizes.append(float(size[j]))
            cand.rings.append(float(ring[j]))
            (confirmed if len(cand.rests) >= late.confirm else kept).append(cand)
        for j in np.flatnonzero(~used):
            kept.append(_Candidate(rest[j], float(size[j]), xy[j], [rest[j]], [float(size[j])], [float(ring[j])]))
        self._candidates = kept
        # Two confirmed at once closer than a marker spacing: a marker seen twice; keep the first.
        out = []
        for cand in confirmed:
            if all(np.linalg.norm(cand.rest - o.rest) >= 0.6 * self._spacing for o in out):
                out.append(cand)
        return out


def _core(grey: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(K,) darkest grey level in the 3x3 pixels at each point."""
    if not len(xy):
        return np.zeros(0)
    h, w = grey.shape
    x = np.clip(np.rint(xy[:, 0]).astype(int), 1, w - 2)
    y = np.clip(np.rint(xy[:, 1]).astype(int), 1, h - 2)
    return np.min([grey[y + dy, x + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0).astype(float)
