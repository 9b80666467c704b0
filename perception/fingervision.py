"""The FingerVision pipeline: one camera frame in, one `TactileState` out.

frame -> checks (shape, dtype, dark, washed out, frozen) -> marker tracking -> Kalman filter ->
force/torque -> proximity vision (object model, mask, moments) -> slip. Calibrate once on frames
with no contact (marker map and background), or load a saved marker map.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from fvfiles.errors import FvtreeError
from perception.calibration import MarkerMap, calibrate_markers
from perception.config import FingerVisionConfig, load_config
from perception.detect import make_detector
from perception.frames import FrameError, ImageQuality, as_bgr
from perception.kalman import MarkerKalman
from perception.late_markers import LateMarkers, NewMarkers
from perception.marker_tracking import make_tracker, neighbour_index
from perception.proximity import ProximityVision
from perception.slip import make_motion, object_slip
from perception.state import FINGERS, OBJECT_UNRELIABLE, MarkerField, ObjectInfo, TactileState
from perception.tracking_kernels import warm_up as warm_tracking_kernels
from perception.wrench import warm_up as warm_wrench_kernel
from perception.wrench import wrench

# Share of the empty view the object colour model may take for the object before every state warns
# that the object's figures are unreliable (pixel mode's default look: 0; a held object: ~0.2).
MAX_BACKGROUND_MATCH = 0.01


def in_view(position: np.ndarray, size: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """(N,) markers whose disc (`size` px across) lies wholly inside the image at `position` (where
    the tracker has or predicts each marker): a firm load pushes the outer markers past the image's
    edge, where no tracker, and no real sensor, sees them; the health rule counts only the others."""
    w, h = image_size
    r = 0.5 * np.asarray(size, float)
    x, y = position[:, 0], position[:, 1]
    return (x >= r) & (y >= r) & (x <= w - 1 - r) & (y <= h - 1 - r)


class NotCalibratedError(FvtreeError, RuntimeError):
    """`process` was called before `calibrate` or `use_marker_map`."""


class FingerVision:
    """One FingerVision sensor: calibrate, then `process(frame, stamp)` every camera frame."""

    def __init__(self, config: FingerVisionConfig | str | Path = "fast", finger: str = "right"):
        if finger not in FINGERS:
            raise ValueError(f"unknown finger {finger!r}; expected one of {', '.join(FINGERS)}")
        self.config = config if isinstance(config, FingerVisionConfig) else load_config(config)
        self.finger = finger
        self.marker_map: MarkerMap | None = None
        self.proximity = ProximityVision(self.config.proximity)
        self._motion = make_motion(self.config.slip) if self.config.proximity.enabled else None
        # A washed-out image is a warning, not a blank: markers stay dark and are judged one by one.
        self._quality = ImageQuality(dataclasses.replace(self.config.health, saturated_share=1.0))
        self._last: MarkerField | None = None
        warm_tracking_kernels()  # the compiled loops loaded now, not on the first frame
        warm_wrench_kernel()

    @property
    def calibrated(self) -> bool:
        """True once a marker map is in use."""
        return self.marker_map is not None

    def calibrate(self, frames: Sequence[np.ndarray]) -> MarkerMap:
        """Find the marker map and the proximity background on frames with no contact and no object."""
        marker_map = calibrate_markers(frames, self.config)
        if self.config.proximity.enabled:
            self.proximity.calibrate_background([as_bgr(f) for f in frames])
        self.use_marker_map(marker_map)
        return marker_map

    def use_marker_map(self, marker_map: MarkerMap) -> None:
        """Track against a given (e.g. loaded) marker map from now on."""
        if len(marker_map) == 0:
            raise ValueError("marker map is empty; recalibrate on frames that show the markers")
        c = self.config
        self.marker_map = marker_map
        self._tracker = make_tracker(c.tracker, c.threshold, make_detector(c.detector),
                                     marker_map.origin, marker_map.size, marker_map.ring)
        self._kalman = (MarkerKalman(c.kalman, 1.0 / c.camera_fps, marker_map.origin, marker_map.size,
                                     neighbour_index(marker_map.origin, c.tracker.neighbours))
                        if c.kalman.enabled else None)
        self._late = LateMarkers(c, marker_map) if c.late.enabled and c.tracker.kind == "window" else None
        self._quality.reset()
        if self._motion is not None:
            self._motion.reset()
        self._last = MarkerField(marker_map.origin, marker_map.origin.copy(), marker_map.size,
                                 marker_map.size.copy(), np.zeros(len(marker_map), bool),
                                 marker_map.image_size)

    def _unhealthy(self, stamp: float, reason: str) -> TactileState:
        last = dataclasses.replace(self._last, valid=np.zeros(len(self._last), bool))
        return TactileState(self.finger, stamp, last, healthy=False, health_reason=reason)

    def process(self, frame: np.ndarray, stamp: float) -> TactileState:
        """Tactile state of one frame; a bad or unusable frame gives an unhealthy state, not an error."""
        if self.marker_map is None:
            raise NotCalibratedError("call calibrate(frames) or use_marker_map(map) before process()")
        try:
            bgr = as_bgr(frame, self.marker_map.image_size)
        except FrameError as exc:
            return self._unhealthy(stamp, str(exc))
        grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
        problem = self._quality.problem(grey)
        if problem:
            return self._unhealthy(stamp, problem)
        warning = self._washed_out()
        track = self._tracker.step(bgr, grey)
        position, size = track.position, track.size
        if self._kalman is not None:
            self._kalman.restart(track.restarted, position, size)
            position, size = self._kalman.update(position, size, track.valid)
        m = self.marker_map
        markers = MarkerField(m.origin, position, m.size, size, track.valid, m.image_size)
        self._last = markers
        if self._late is not None:
            self._adopt(self._late.search(bgr, grey, markers))
        w = self.config.wrench
        force, torque = wrench(markers, self.finger, w.normal_mode, w.averaging,
                               np.asarray(w.force_scale), np.asarray(w.torque_scale))
        obj, slip = self._proximity(bgr)
        seen = in_view(track.position, m.size, m.image_size)
        tracked = float((track.valid & seen).sum() / max(seen.sum(), 1))
        healthy = tracked >= self.config.health.min_tracked
        out = "" if seen.all() else f", {(~seen).sum()} of {len(seen)} pushed out of the image"
        reason = "" if healthy else (f"only {tracked:.0%} of markers tracked (of those in view; "
                                     f"< {self.config.health.min_tracked:.0%}{out}); contact occluding "
                                     f"the skin, lighting changed, or recalibration needed")
        reason = "; ".join(r for r in (reason, warning, self._object_warning()) if r)  # on a healthy state: a warning
        return TactileState(self.finger, stamp, markers, force, torque, obj, slip, healthy, reason)

    def _adopt(self, new: NewMarkers | None) -> None:
        """Append markers found after calibration to the map, the tracker and the filter (from the
        next frame on; existing indices stay)."""
        if new is None:
            return
        self.marker_map = self.marker_map.appended(new.origin, new.size, new.ring)
        self._tracker.add(new.origin, new.size, new.position, new.ring)
        if self._kalman is not None:
            self._kalman.add(new.position, new.size, neighbour_index(self.marker_map.origin,
                                                                     self.config.tracker.neighbours))

    def _washed_out(self) -> str:
        """A warning when much of the image is saturated (markers are still tracked one by one)."""
        saturated = self._quality.saturated  # of the frame just checked
        if saturated <= self.config.health.saturated_share:
            return ""
        return f"image washed out ({saturated:.0%} of pixels saturated); reduce exposure or glare"

    def _object_warning(self) -> str:
        """A warning when the object colour model also matches the empty view (the paper's failure:
        lighting, glare or a background of the object's colour), so the object's area and centroid
        are not to be trusted."""
        if not self.config.proximity.enabled:
            return ""
        match = self.proximity.background_match()
        if match <= MAX_BACKGROUND_MATCH:
            return ""
        return (f"{OBJECT_UNRELIABLE} {match:.1%} of the empty view (glare, lighting or a background "
                "of the object's colour): the object's area and centroid are unreliable; mark the object "
                "again or change its colour or the background")

    def _proximity(self, bgr: np.ndarray) -> tuple[ObjectInfo, float]:
        if not self.config.proximity.enabled:
            return ObjectInfo(), 0.0
        frame = self.proximity.prepare(bgr)
        motion = self._motion(frame) if self._motion is not None else None
        if motion is not None:
            self.proximity.learn(frame, motion)
        if not self.proximity.has_model:
            return ObjectInfo(), 0.0  # nothing to look for yet; motion models keep adapting
        obj_mask, obj_wide = self.proximity.object_masks(frame)
        if motion is None:
            return self.proximity.describe(obj_mask), 0.0
        slip, cells = object_slip(motion, frame, obj_wide)
        return self.proximity.describe(obj_mask, cells), slip
