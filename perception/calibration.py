"""Marker map: the calibrated marker origins and sizes, found on frames with no contact, and its
YAML file format.

Calibration follows the original `Calibrate`: detect on the first frame, track the following
frames from zero displacement, and drop every marker that drifts by more than `max_drift` px or
changes size by more than `max_size_drift` px (diameter) between its tracked frames, or that is
tracked in fewer than `min_tracked` of the frames (0: the 2018 rule, where a lost marker keeps its
last values and only drift counts). It then also drops markers whose size is far from the typical
marker's (dirt, dark background spots), pale spots (not black ink), near-duplicates, and markers
in dark clutter (their ring darker than `max_ring`, or than `lattice_ring` where the lattice of the
clean markers continues through them: a marker beside a dark edge is kept, a dark spot is not).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import yaml

from fvfiles.errors import FvtreeError
from perception.config import FingerVisionConfig
from perception.detect import make_detector, marker_mask
from perception.frames import FrameError, as_bgr
from perception.marker_tracking import make_tracker, neighbour_index

FORMAT_KEY = "fingervision_marker_map"
FORMAT_VERSION = 1
MIN_MARKERS = 3


class CalibrationError(FvtreeError, RuntimeError):
    """Calibration found no usable marker map; the message says what to check."""


@dataclass(frozen=True)
class MarkerMap:
    """Calibrated markers of one sensor: origins (N, 2) px, diameters (N,) px, image size (W, H), and
    the dark share of the ring around each marker at calibration (N,) (None: unknown, taken as 0)."""

    origin: np.ndarray
    size: np.ndarray
    image_size: tuple[int, int]
    ring: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.size)

    def without_near(self, point: Sequence[float], radius: float = 30.0) -> MarkerMap:
        """A copy without the markers within `radius` px of `point` (hand edit, `RemovePointAt`)."""
        keep = np.linalg.norm(self.origin - np.asarray(point, float), axis=1) > radius
        return MarkerMap(self.origin[keep], self.size[keep], self.image_size,
                         None if self.ring is None else self.ring[keep])

    def appended(self, origin: np.ndarray, size: np.ndarray, ring: np.ndarray) -> MarkerMap:
        """A copy with markers added at the end (found after calibration): existing indices stay."""
        old_ring = np.zeros(len(self)) if self.ring is None else self.ring
        return MarkerMap(np.concatenate([self.origin, origin]), np.concatenate([self.size, size]), self.image_size,
                         np.concatenate([old_ring, ring]))

    def save(self, path: str | Path) -> None:
        """Write the map as YAML (one `[x, y, diameter, ring]` row per marker; ring only if known)."""
        rows = [[round(float(x), 4), round(float(y), 4), round(float(s), 4)]
                for (x, y), s in zip(self.origin, self.size)]
        if self.ring is not None:
            rows = [row + [round(float(r), 4)] for row, r in zip(rows, self.ring)]
        doc = {FORMAT_KEY: FORMAT_VERSION, "image_size": list(self.image_size), "markers": rows}
        Path(path).write_text(yaml.safe_dump(doc, default_flow_style=None, sort_keys=False))

    @classmethod
    def load(cls, path: str | Path) -> MarkerMap:
        """Read a map written by `save`; malformed files raise `CalibrationError` naming the problem."""
        try:
            doc = yaml.safe_load(Path(path).read_text())
        except OSError as exc:
            raise CalibrationError(f"cannot read marker map {path}: {exc.strerror}") from None
        except yaml.YAMLError as exc:
            raise CalibrationError(f"{path}: not valid YAML: {exc}") from None
        if not isinstance(doc, dict) or doc.get(FORMAT_KEY) != FORMAT_VERSION:
            raise CalibrationError(f"{path}: not a marker map (expected '{FORMAT_KEY}: {FORMAT_VERSION}')")
        try:
            rows = np.asarray(doc["markers"], float)
            rows = rows.reshape(0, 3) if rows.size == 0 else rows
            w, h = (int(v) for v in doc["image_size"])
            if rows.ndim != 2 or rows.shape[1] not in (3, 4):
                raise ValueError(f"rows of {rows.shape[-1] if rows.ndim else 0} numbers")
        except (KeyError, TypeError, ValueError) as exc:
            raise CalibrationError(f"{path}: needs image_size [W, H] and markers [[x, y, size], ...] "
                                   f"or [[x, y, size, ring], ...] ({exc})") from None
        ring = rows[:, 3].copy() if rows.shape[1] == 4 else None
        return cls(rows[:, :2].copy(), rows[:, 2].copy(), (w, h), ring)


def lattice_steps(lattice: np.ndarray) -> tuple[np.ndarray, float]:
    """((L, 6, 2) one step on from each marker a along each row through it, a + (a - b) for its
    neighbours b; the median marker spacing in px)."""
    nb = neighbour_index(lattice, 6)
    step = lattice[:, None, :] - lattice[nb]  # from each neighbour to the marker
    return lattice[:, None, :] + step, float(np.median(np.linalg.norm(step[:, 0], axis=1)))


def on_lattice(points: np.ndarray, lattice: np.ndarray, tolerance: float = 0.15) -> np.ndarray:
    """(K,) points where the marker lattice continues: within `tolerance` marker spacings of a step on
    (`lattice_steps`) from a lattice marker near the point. A dark spot or an object edge between the
    rows is not on it."""
    out = np.zeros(len(points), bool)
    if len(lattice) < 3 or not len(points):
        return out
    ahead, spacing = lattice_steps(lattice)
    for k, p in enumerate(points):
        near = np.argsort(np.linalg.norm(lattice - p, axis=1))[:6]
        out[k] = np.linalg.norm(ahead[near] - p, axis=2).min() < tolerance * spacing
    return out


def _drop_duplicates(origin: np.ndarray, size: np.ndarray, min_dist: float) -> np.ndarray:
    """Keep mask without the smaller of any two markers closer than `min_dist`."""
    keep = np.ones(len(size), bool)
    for i in np.argsort(-size):
        if keep[i]:
            close = np.linalg.norm(origin - origin[i], axis=1) < min_dist
            close[i] = False
            keep &= ~close
    return keep


def calibrate_markers(frames: Sequence[np.ndarray], config: FingerVisionConfig) -> MarkerMap:
    """Marker map from frames with no contact (first `config.calibration.n_frames` of them)."""
    cal = config.calibration
    if len(frames) < 2:
        raise CalibrationError(f"calibration needs at least 2 frames with no contact, got {len(frames)}")
    try:
        images = [as_bgr(f) for f in list(frames)[: cal.n_frames]]
        size = (images[0].shape[1], images[0].shape[0])
        images = [as_bgr(f, size) for f in images]
    except FrameError as exc:
        raise CalibrationError(f"bad calibration frame: {exc}") from None
    greys = [cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in images]
    blobs = make_detector(config.detector).detect(marker_mask(images[0], greys[0], config.threshold))
    if len(blobs) < MIN_MARKERS:
        raise CalibrationError(
            f"found {len(blobs)} markers in the first calibration frame; point the sensor at a plain "
            f"bright surface, check the lighting, or tune threshold (mode {config.threshold.mode!r})")
    xy, diameter = blobs.xy, blobs.size
    for _ in range(3):  # re-track the survivors so a dropped blob cannot disturb its neighbours
        keep, origin, diameter, ring = _stable(images, greys, xy, diameter, config)
        xy, origin, diameter, ring = xy[keep], origin[keep], diameter[keep], ring[keep]
        if keep.all() or not keep.any():
            break
    keep = _drop_duplicates(origin, diameter, config.detector.min_dist_between)
    origin, diameter, ring = origin[keep], diameter[keep], ring[keep]
    if len(origin) < MIN_MARKERS:
        raise CalibrationError(
            f"only {len(origin)} of {len(blobs)} markers stayed still over {len(images)} frames; "
            f"calibrate with no contact and a steady camera (limits: {cal.max_drift} px, "
            f"{cal.max_size_drift} px size)")
    return MarkerMap(origin.copy(), diameter.copy(), size, ring.copy())


def _stable(images, greys, xy, diameter, config: FingerVisionConfig):
    """Track candidate markers over the frames: (stable mask, origins, diameters, ring dark shares)
    per candidate."""
    cal = config.calibration
    # The size gate is opened: the tracker may measure size slightly differently from the
    # detector; stability is judged on the tracker's own measurements. A dark edge next to a marker
    # is recorded (its ring's dark share), not held against it. No candidate is re-acquired on
    # another blob: one the tracker loses at rest is not a marker (a background spot).
    loose = dataclasses.replace(config.tracker, max_size_change=np.inf, consistency=0.0, max_ring_dark=1.0,
                                reacquire=0.0)
    tracker = make_tracker(loose, config.threshold, make_detector(config.detector), xy, diameter)
    tracker.regrow = False  # the candidates' sizes are the detector's: no growth to measure against them
    tracks, rings = [], []
    for f, g in zip(images, greys):
        tracks.append(tracker.step(f, g))
        rings.append(tracker.ring.copy())
    ring = np.median(rings, axis=0)
    pos = np.stack([t.position for t in tracks])  # (F, N, 2)
    sizes = np.stack([t.size for t in tracks])  # (F, N)
    valid = np.stack([t.valid for t in tracks])  # (F, N)
    keep = valid.mean(axis=0) >= cal.min_tracked
    # Drift over the tracked frames only (a lost frame repeats the last tracked values, as the original).
    first = pos[valid.argmax(axis=0), np.arange(pos.shape[1])]
    drift = np.where(valid, np.linalg.norm(pos - first, axis=2), 0.0).max(axis=0)
    size_first = sizes[valid.argmax(axis=0), np.arange(pos.shape[1])]
    keep &= drift <= cal.max_drift
    keep &= np.where(valid, np.abs(sizes - size_first), 0.0).max(axis=0) <= cal.max_size_drift
    weight = valid / np.maximum(valid.sum(axis=0), 1)
    origin = pos[0] if cal.origin == "first" else np.einsum("fn,fnd->nd", weight, pos)
    diameter = sizes[0] if cal.origin == "first" else (weight * sizes).sum(axis=0)
    # A marker in dark clutter: its measurements cannot be checked. One beside a dark edge is kept
    # where the lattice of the clean markers continues (a dark spot between the rows is not) and the
    # edge does not swell its measured size (then it would bias its centre too).
    clean = keep & (ring <= cal.max_ring)
    beside_edge = (ring <= cal.lattice_ring) & on_lattice(origin, origin[clean])
    if clean.any():
        beside_edge &= diameter <= 1.1 * np.median(diameter[clean])
    keep &= clean | beside_edge
    if keep.any():
        typical = np.median(diameter[keep])
        keep &= (diameter > 0.5 * typical) & (diameter < 1.6 * typical)
        # Markers are black ink: a spot whose core is nearer the image's typical grey than the
        # typical marker core is a pale smudge or a shadow, not a marker.
        core = _core_grey(greys, origin)
        keep &= core <= 0.5 * (np.median(core[keep]) + float(np.median(greys[0])))
    return keep, origin, diameter, ring


def _core_grey(greys, origin: np.ndarray) -> np.ndarray:
    """(N,) darkest grey level in the 3x3 pixels at each origin, averaged over the frames."""
    mean = np.mean(greys, axis=0, dtype=np.float32)
    h, w = mean.shape
    x = np.clip(np.rint(origin[:, 0]).astype(int), 1, w - 2)
    y = np.clip(np.rint(origin[:, 1]).astype(int), 1, h - 2)
    return np.min([mean[y + dy, x + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
