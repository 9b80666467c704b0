"""Proximity vision: what the camera sees through the skin (after the original `TObjDetTrackBSP`).

A background colour histogram (frames with no object), an object colour model (HSV histograms
learned from moving pixels in detect mode, or added by hand from a masked frame), back-projection
into an object mask, and image moments -> area, centroid, orientation, plus 3x3 cell summaries.
Everything runs on a copy of the frame resized to `width x height`.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numba import njit

from perception.config import ProximityConfig
from perception.state import ObjectInfo

_KERNEL = np.ones((3, 3), np.uint8)
_RANGES = (180, 256, 256)  # H, S, V value ranges of an 8-bit OpenCV HSV image


@dataclass(frozen=True)
class ProxFrame:
    """One frame at the proximity resolution: BGR, the not-black mask and HSV histogram bins."""

    bgr: np.ndarray
    not_black: np.ndarray  # uint8 255 where V > thresh_blk_v (markers and dark areas are excluded)
    bins: np.ndarray  # int, flat index of each pixel's H x S x V histogram bin


def cell_means(mask: np.ndarray) -> np.ndarray:
    """(3, 3) mean of `mask` (0..255) over floor(W/3) x floor(H/3) cells (from the integral image:
    exact integer sums, faster than a reshaped mean)."""
    h, w = mask.shape
    ch, cw = h // 3, w // 3
    corners = cv2.integral(mask)[::ch, ::cw][:4, :4].astype(np.float64)
    return (corners[1:, 1:] - corners[:-1, 1:] - corners[1:, :-1] + corners[:-1, :-1]) / (ch * cw)


@njit(cache=True, nogil=True)
def hsv_bins(hsv, lh, ls, lv, thresh):  # pragma: no cover - compiled
    """(not-black mask: 255 where V > `thresh`, else 0; flat histogram bin of each pixel: the sum of
    its H, S and V look-ups, saturated at 65535) of an (H, W, 3) uint8 HSV image, in one pass (what
    a split, a threshold and three look-ups and two adds did in eight)."""
    height, width = hsv.shape[0], hsv.shape[1]
    not_black = np.empty((height, width), np.uint8)
    bins = np.empty((height, width), np.uint16)
    for y in range(height):
        for x in range(width):
            v = hsv[y, x, 2]
            not_black[y, x] = 255 if v > thresh else 0
            bins[y, x] = min(np.int64(lh[hsv[y, x, 0]]) + ls[hsv[y, x, 1]] + lv[v], 65535)
    return not_black, bins


@njit(cache=True, nogil=True)
def back_project(lut, bins, not_black):  # pragma: no cover - compiled
    """`lut[bins] & not_black` (uint8), in one pass."""
    out = np.empty(bins.shape, np.uint8)
    for y in range(bins.shape[0]):
        for x in range(bins.shape[1]):
            out[y, x] = lut[bins[y, x]] & not_black[y, x]
    return out


class ProximityVision:
    """Background and object colour models, object mask and its shape summary."""

    def __init__(self, cfg: ProximityConfig):
        self.cfg = cfg
        # Per-channel lookup tables value -> its share of the flat bin index (H x S x V, row-major);
        # histograms and back-projection share them. (Done in numpy: cv2.calcBackProject reads a
        # 3-D numpy histogram as a 2-D multi-channel image.)
        strides = (cfg.bins[1] * cfg.bins[2], cfg.bins[2], 1)
        self._luts = [(np.minimum(np.arange(256) * n // r, n - 1) * stride).astype(np.uint16)
                      for n, r, stride in zip(cfg.bins, _RANGES, strides)]
        self._n_bins = int(np.prod(cfg.bins))
        self.background: np.ndarray | None = None
        self._models: deque[np.ndarray] = deque(maxlen=cfg.n_models)
        self._models.append(self._zero())
        self.learning = False
        self._frames = 0
        self._mask_lut: tuple[np.ndarray, np.ndarray] | None = None  # (tracking model, its binary LUT)
        self._empty: ProxFrame | None = None  # the first background frame: the view with no object
        self._match: tuple[np.ndarray, float] | None = None  # (tracking model, its background match)
        pixel = np.zeros((1, 1), np.uint8)  # the compiled loops loaded now, not on the first frame
        back_project(self._luts[0].astype(np.uint8), hsv_bins(np.zeros((1, 1, 3), np.uint8), *self._luts, 0)[1], pixel)

    def _zero(self) -> np.ndarray:
        return np.zeros(self.cfg.bins, np.float32)

    def _hist(self, frame: ProxFrame, mask: np.ndarray | None) -> np.ndarray:
        """Un-normalised H x S x V histogram of the pixels where `mask` is nonzero (all if None)."""
        bins = frame.bins if mask is None else frame.bins[mask > 0]
        counts = np.bincount(bins.ravel(), minlength=self._n_bins)
        return counts.reshape(self.cfg.bins).astype(np.float32)

    def prepare(self, bgr: np.ndarray) -> ProxFrame:
        """Resize (nearest, as the original) and convert one frame."""
        size = (self.cfg.width, self.cfg.height)
        small = bgr if (bgr.shape[1], bgr.shape[0]) == size else cv2.resize(
            bgr, size, interpolation=cv2.INTER_NEAREST)
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        not_black, bins = hsv_bins(hsv, *self._luts, int(self.cfg.thresh_blk_v))
        return ProxFrame(small, not_black, bins)

    def calibrate_background(self, frames: Sequence[np.ndarray]) -> None:
        """Background histogram: the mean over up to `n_bg_frames` frames with no object."""
        if not frames:
            raise ValueError("background calibration needs at least one frame with no object")
        prepared = [self.prepare(f) for f in frames[: self.cfg.n_bg_frames]]
        self.background = np.mean([self._hist(f, None) for f in prepared], axis=0).astype(np.float32)
        self._empty, self._match = prepared[0], None

    def background_match(self) -> float:
        """Share of the empty view (the first background frame) the object mask covers: what the
        tracking model takes for the object where there is none (its colours are the background's,
        glare's or a colour cast's). 0 without a model or a background; computed again only when the
        tracking model changes."""
        if self._empty is None or not self.has_model:
            return 0.0
        model = self._models[-1]
        if self._match is None or self._match[0] is not model:
            obj, _ = self.object_masks(self._empty)
            self._match = (model, float(np.count_nonzero(obj)) / obj.size)
        return self._match[1]

    @property
    def has_model(self) -> bool:
        """True once an object colour model exists (learned or added)."""
        return bool(self._models[0].any())

    def start_learning(self) -> None:
        """Detect mode: learn the object model from moving pixels (needs a background first)."""
        if self.background is None:
            raise RuntimeError("calibrate the background (no object in view) before learning an object")
        self.learning, self._frames = True, 0

    def stop_learning(self) -> None:
        """Freeze the object model (the original calls this before grasping)."""
        self.learning = False

    def add_object(self, bgr: np.ndarray, mask: np.ndarray, gain: float = 1.0) -> None:
        """Add the colours under `mask` (full-frame, nonzero = object) to the model, as a hand edit."""
        frame = self.prepare(bgr)
        small = cv2.resize(np.asarray(mask, np.uint8), (self.cfg.width, self.cfg.height),
                           interpolation=cv2.INTER_NEAREST)
        small = cv2.bitwise_and((small > 0).view(np.uint8) * np.uint8(255), frame.not_black)
        added = gain * self._hist(frame, small)
        for i, model in enumerate(self._models):
            self._models[i] = np.minimum(model + added, 255.0).astype(np.float32)

    def learn(self, frame: ProxFrame, motion: np.ndarray) -> None:
        """One detect-mode step: add moving colours not explained by the background to every model."""
        if not self.learning or self.background is None:
            return
        period = max(1, self.cfg.frames_in_hist // self.cfg.n_models)
        if self._frames and self._frames % period == 0:
            self._models.appendleft(self._zero())  # newest first; the deque drops the oldest
        self._frames += 1
        moving = cv2.bitwise_and(motion, frame.not_black)
        gain = self.cfg.f_gain * np.maximum(self._hist(frame, moving) - self.cfg.f_bg * self.background, 0)
        for i, model in enumerate(self._models):
            self._models[i] = np.minimum(model + gain, 255.0).astype(np.float32)

    def object_masks(self, frame: ProxFrame) -> tuple[np.ndarray, np.ndarray]:
        """(object mask, dilated object mask) from back-projecting the oldest (tracking) model."""
        # The original keeps values (TOZERO); erosion, dilation and binary moments only see the
        # support, so a binary mask gives the same result and ANDs cleanly with motion masks.
        back = back_project(self._binary_lut(), frame.bins, frame.not_black)
        obj = cv2.erode(back, _KERNEL, iterations=self.cfg.n_erode) if self.cfg.n_erode else back
        wide = cv2.dilate(obj, _KERNEL, iterations=self.cfg.n_dilate) if self.cfg.n_dilate else obj
        return obj, wide

    def _binary_lut(self) -> np.ndarray:
        """Bin -> 255 where the tracking model back-projects above `mask_threshold`, else 0; made
        again only when that model changes (learning or a hand edit)."""
        model = self._models[-1]
        if self._mask_lut is None or self._mask_lut[0] is not model:
            back = np.minimum(model.ravel() * self.cfg.backproj_scale, 255).astype(np.uint8)
            self._mask_lut = (model, np.where(back > self.cfg.mask_threshold, 255, 0).astype(np.uint8))
        return self._mask_lut[1]

    def describe(self, obj_mask: np.ndarray, motion_cells: np.ndarray | None = None) -> ObjectInfo:
        """Area share, centroid (about the image centre, over (W + H) / 2), orientation, 3x3 fill of
        a 0/255 object mask, and the moving share per cell when given (slip's; else zeros)."""
        h, w = obj_mask.shape
        m = cv2.moments(obj_mask)  # of the 0/255 mask: 255 x the binary moments, and quicker
        area = m["m00"] / (255.0 * w * h)
        cells = cell_means(obj_mask) / 255.0
        moving = np.zeros((3, 3)) if motion_cells is None else motion_cells
        if area < self.cfg.min_area:
            return ObjectInfo(False, area, np.zeros(2), 0.0, cells, moving)
        div = (w + h) / 2.0
        centroid = np.array([(m["m10"] / m["m00"] - w / 2.0) / div, (m["m01"] / m["m00"] - h / 2.0) / div])
        angle = 0.5 * np.arctan2(2.0 * m["mu11"], m["mu20"] - m["mu02"])
        return ObjectInfo(True, area, centroid, float(angle), cells, moving)
