"""Marker map: the calibrated marker origins and sizes, found on frames with no contact, and its
YAML file format.

Calibration follows the original `Calibrate`: detect on the first frame, track the following
frames from zero displacement, and drop every marker that is lost once, drifts by more than
`max_drift` px or changes size by more than `max_size_drift` px. It then also drops markers whose
size is far from the typical marker's (dirt, dark background spots) and near-duplicates.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import cv2
import numpy as np
import yaml

from perception.config import FingerVisionConfig
from perception.detect import make_detector, marker_mask
from perception.errors import FvtreeError
from perception.frames import FrameError, as_bgr
from perception.marker_tracking import make_tracker

FORMAT_KEY = "fingervision_marker_map"
FORMAT_VERSION = 1
MIN_MARKERS = 3


class CalibrationError(FvtreeError, RuntimeError):
    """Calibration found no usable marker map; the message says what to check."""


@dataclass(frozen=True)
class MarkerMap:
    """Calibrated markers of one sensor: origins (N, 2) px, diameters (N,) px, image size (W, H)."""

    origin: np.ndarray
    size: np.ndarray
    image_size: tuple[int, int]

    def __len__(self) -> int:
        return len(self.size)

    def without_near(self, point: Sequence[float], radius: float = 30.0) -> "MarkerMap":
        """A copy without the markers within `radius` px of `point` (hand edit, `RemovePointAt`)."""
        keep = np.linalg.norm(self.origin - np.asarray(point, float), axis=1) > radius
        return MarkerMap(self.origin[keep], self.size[keep], self.image_size)

    def save(self, path: str | Path) -> None:
        """Write the map as YAML (one `[x, y, diameter]` row per marker)."""
        rows = [[round(float(x), 4), round(float(y), 4), round(float(s), 4)]
                for (x, y), s in zip(self.origin, self.size)]
        doc = {FORMAT_KEY: FORMAT_VERSION, "image_size": list(self.image_size), "markers": rows}
        Path(path).write_text(yaml.safe_dump(doc, default_flow_style=None, sort_keys=False))

    @classmethod
    def load(cls, path: str | Path) -> "MarkerMap":
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
            rows = np.asarray(doc["markers"], float).reshape(-1, 3)
            w, h = (int(v) for v in doc["image_size"])
        except (KeyError, TypeError, ValueError) as exc:
            raise CalibrationError(f"{path}: needs image_size [W, H] and markers [[x, y, size], ...] "
                                   f"({exc})") from None
        return cls(rows[:, :2].copy(), rows[:, 2].copy(), (w, h))


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
        keep, origin, diameter = _stable(images, greys, xy, diameter, config)
        xy, origin, diameter = xy[keep], origin[keep], diameter[keep]
        if keep.all() or not keep.any():
            break
    keep = _drop_duplicates(origin, diameter, config.detector.min_dist_between)
    origin, diameter = origin[keep], diameter[keep]
    if len(origin) < MIN_MARKERS:
        raise CalibrationError(
            f"only {len(origin)} of {len(blobs)} markers stayed still over {len(images)} frames; "
            f"calibrate with no contact and a steady camera (limits: {cal.max_drift} px, "
            f"{cal.max_size_drift} px size)")
    return MarkerMap(origin.copy(), diameter.copy(), size)


def _stable(images, greys, xy, diameter, config: FingerVisionConfig):
    """Track candidate markers over the frames: (stable mask, origins, diameters) per candidate."""
    cal = config.calibration
    # The size gate is opened: the tracker may measure size slightly differently from the
    # detector; stability is judged on the tracker's own measurements.
    loose = dataclasses.replace(config.tracker, max_size_change=np.inf, consistency=0.0)
    tracker = make_tracker(loose, config.threshold, make_detector(config.detector), xy, diameter)
    tracks = [tracker.step(f, g) for f, g in zip(images, greys)]
    pos = np.stack([t.position for t in tracks])  # (F, N, 2)
    sizes = np.stack([t.size for t in tracks])  # (F, N)
    keep = np.all([t.valid for t in tracks], axis=0)
    keep &= np.linalg.norm(pos - pos[0], axis=2).max(axis=0) <= cal.max_drift
    keep &= np.abs(sizes - sizes[0]).max(axis=0) <= cal.max_size_drift
    origin = pos[0] if cal.origin == "first" else pos.mean(axis=0)
    diameter = sizes[0] if cal.origin == "first" else sizes.mean(axis=0)
    if keep.any():
        typical = np.median(diameter[keep])
        keep &= (diameter > 0.5 * typical) & (diameter < 2.0 * typical)
    return keep, origin, diameter
