"""Slip: how much of the object moves in the image, on the original `mv_s` scale.

Two motion sources, selectable: `mog2`, the original's MOG2 background subtractor (history 30,
variance threshold 10, shadows), and `flow`, DIS optical flow (moving = speed above `min_speed`).
Motion is then restricted to object pixels (the dilated object mask, not-black pixels) and summed
over 3x3 cells as the original: slip = sum over cells of 100 * mean(cell) / (320 * 240). The
normaliser is fixed at the original 320x240 so the scale does not depend on the processing size.
"""

from __future__ import annotations

import cv2
import numpy as np

from perception.config import SlipConfig
from perception.proximity import ProxFrame, cell_means

_REFERENCE_PIXELS = 320 * 240
_DIS_PRESETS = {"ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
                "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
                "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM}


class Mog2Motion:
    """Foreground of a MOG2 background model: 255 motion, 127 shadow, 0 still."""

    def __init__(self, cfg: SlipConfig):
        self.cfg = cfg
        self.reset()

    def reset(self) -> None:
        """Start a fresh background model."""
        self._mog = cv2.createBackgroundSubtractorMOG2(self.cfg.history, self.cfg.var_threshold,
                                                       self.cfg.shadows)

    def __call__(self, frame: ProxFrame) -> np.ndarray:
        step = self.cfg.step
        if step <= 1:
            return self._mog.apply(frame.bgr, learningRate=self.cfg.learning_rate)
        # Every step-th pixel (a step^2 share of the work): each keeps its own model, as at full size.
        sparse = self._mog.apply(every_nth(frame.bgr, step), learningRate=self.cfg.learning_rate)
        h, w = frame.bgr.shape[:2]
        return cv2.resize(sparse, (w, h), interpolation=cv2.INTER_NEAREST)


def every_nth(bgr: np.ndarray, step: int) -> np.ndarray:
    """`bgr[::step, ::step]` as a contiguous image. Where `step` divides both sides, OpenCV's nearest
    resize picks exactly those pixels (source x = step * x) at a fifth of the time numpy copies a
    strided 3-channel view in (it moves the 3 bytes of each pixel one at a time)."""
    h, w = bgr.shape[:2]
    if h % step or w % step:
        return np.ascontiguousarray(bgr[::step, ::step])
    return cv2.resize(bgr, (w // step, h // step), interpolation=cv2.INTER_NEAREST)


class FlowMotion:
    """Pixels whose DIS optical-flow speed since the last frame exceeds `min_speed` (px at 320x240).

    The static black markers would pin the patch-based flow to zero, so they are first removed
    with a grey closing a little larger than a marker (11 px at 320x240)."""

    def __init__(self, cfg: SlipConfig):
        self.cfg = cfg
        self._dis = cv2.DISOpticalFlow.create(_DIS_PRESETS[cfg.flow_preset])
        self._kernel: np.ndarray | None = None
        self.reset()

    def reset(self) -> None:
        """Forget the previous frame."""
        self._prev: np.ndarray | None = None

    def __call__(self, frame: ProxFrame) -> np.ndarray:
        scale = frame.bgr.shape[1] / 320.0  # sizes and speeds are given at the original 320x240
        if self._kernel is None:
            side = 2 * int(np.ceil(5.5 * scale)) + 1
            self._kernel = np.ones((side, side), np.uint8)
        grey = cv2.morphologyEx(cv2.cvtColor(frame.bgr, cv2.COLOR_BGR2GRAY), cv2.MORPH_CLOSE, self._kernel)
        prev, self._prev = self._prev, grey
        if prev is None or prev.shape != grey.shape:
            return np.zeros_like(grey)
        flow = self._dis.calc(prev, grey, None)
        speed2 = flow[:, :, 0] ** 2 + flow[:, :, 1] ** 2
        return (speed2 > (self.cfg.min_speed * scale) ** 2).view(np.uint8) * np.uint8(255)


def make_motion(cfg: SlipConfig) -> Mog2Motion | FlowMotion | None:
    """The motion source named by `cfg.method` (None when slip is off)."""
    if cfg.method == "off":
        return None
    return FlowMotion(cfg) if cfg.method == "flow" else Mog2Motion(cfg)


def object_slip(motion: np.ndarray, frame: ProxFrame, obj_wide: np.ndarray) -> tuple[float, np.ndarray]:
    """(slip, 3x3 cell motion share 0..1): motion restricted to not-black object pixels."""
    moving = cv2.bitwise_and(cv2.bitwise_and(motion, obj_wide), frame.not_black)
    cells = cell_means(moving)
    return float(100.0 * cells.sum() / _REFERENCE_PIXELS), cells / 255.0
