"""Frame checks: reject malformed frames with a reason and flag unusable images (dark, washed out,
frozen) before any stage looks at them."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from numba import njit

from fvfiles.errors import FvtreeError
from perception.config import HealthConfig


class FrameError(FvtreeError, ValueError):
    """A frame cannot be processed at all (wrong type, shape, dtype or size)."""


def as_bgr(frame: object, size: tuple[int, int] | None = None) -> np.ndarray:
    """Return the frame as a contiguous (H, W, 3) uint8 BGR image, or raise `FrameError` saying why."""
    if not isinstance(frame, np.ndarray):
        raise FrameError(f"frame is a {type(frame).__name__}, expected a numpy uint8 image")
    if frame.size == 0:
        raise FrameError(f"frame is empty (shape {frame.shape}); is the camera delivering images?")
    if frame.dtype != np.uint8:
        raise FrameError(f"frame dtype is {frame.dtype}, expected uint8 (8-bit BGR as from cv2)")
    if frame.ndim == 2:
        frame = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
    elif frame.ndim != 3 or frame.shape[2] not in (3, 4):
        raise FrameError(f"frame shape is {frame.shape}, expected (H, W, 3) BGR or (H, W) grey")
    elif frame.shape[2] == 4:
        frame = cv2.cvtColor(frame, cv2.COLOR_BGRA2BGR)
    if size is not None and (frame.shape[1], frame.shape[0]) != tuple(size):
        raise FrameError(f"frame is {frame.shape[1]}x{frame.shape[0]} but the sensor was calibrated "
                         f"at {size[0]}x{size[1]}; recalibrate or fix the camera resolution")
    return np.ascontiguousarray(frame)


GRID = 4  # regions per side for the partly-frozen check
TEXTURED = 3.0  # grey std above which a region shows content (a clipped black or white one does not)
LIVE = 0.5  # a region with fewer identical pixels than this is live


class ImageQuality:
    """Per-frame usability check of the grey image: too dark, washed out, frozen camera, or a part
    of the image frozen while the rest lives."""

    def __init__(self, config: HealthConfig):
        self.config = config
        self._last: np.ndarray | None = None
        self._repeats = 0
        self._region_repeats = np.zeros(GRID * GRID, dtype=int)
        self.saturated = 0.0  # share of saturated pixels (>= 250) in the last frame checked
        blank = np.zeros((GRID, GRID), np.uint8)
        region_stats(blank, blank, GRID)  # the compiled check loaded now, not on the first frame

    def reset(self) -> None:
        """Forget the previous frame (after a recalibration or camera restart)."""
        self._last, self._repeats = None, 0
        self._region_repeats[:] = 0

    def _frozen_region(self, sample: np.ndarray, last: np.ndarray) -> str:
        """Why a part of the image counts as frozen, or "": see HealthConfig.frozen_region_frames."""
        count, spread = region_stats(sample, last, GRID)
        n = (sample.shape[0] // GRID) * (sample.shape[1] // GRID)
        same = count / n
        textured = spread > TEXTURED * TEXTURED * n * n  # std > TEXTURED, in exact integers
        frozen = (same >= self.config.frozen_region_share) & textured & (same.min() < LIVE)
        self._region_repeats = np.where(frozen, self._region_repeats + 1, 0)
        worst = int(self._region_repeats.argmax())
        if self._region_repeats[worst] < self.config.frozen_region_frames:
            return ""
        row, col = divmod(worst, GRID)
        return (f"part of the image frozen (region {row + 1},{col + 1} of {GRID}x{GRID} unchanged for "
                f"{self._region_repeats[worst]} frames while the rest changes): a decoder concealing "
                "truncated or corrupt frames, or a stuck sensor area")

    def problem(self, grey: np.ndarray) -> str:
        """Why this grey frame is unusable, or "" when it is fine."""
        sample = grey[::4, ::4].copy()  # 1/16 of the pixels is plenty for global statistics (contiguous)
        part = ""
        if self._last is not None and np.array_equal(sample, self._last):
            self._repeats += 1
        else:
            self._repeats = 0
            if self.config.frozen_region_frames and self._last is not None and self._last.shape == sample.shape:
                part = self._frozen_region(sample, self._last)
        self._last = sample
        mean = cv2.mean(sample)[0]
        self.saturated = saturated = cv2.countNonZero(cv2.compare(sample, 250, cv2.CMP_GE)) / sample.size
        if mean < self.config.dark_level:
            return f"image too dark (mean grey {mean:.0f} < {self.config.dark_level:.0f}); check lighting"
        if saturated > self.config.saturated_share:
            return f"image washed out ({saturated:.0%} of pixels saturated); reduce exposure or glare"
        if self._repeats >= self.config.frozen_frames:
            return f"camera frozen ({self._repeats + 1} identical frames)"
        return part


@njit(cache=True, nogil=True)
def region_stats(now, last, grid):  # pragma: no cover - compiled
    """Per region of a `grid` x `grid` split of the (H, W) uint8 image `now` (the rows and columns
    left over by the split ignored), row-major: (pixels equal to `last`'s, n^2 x the variance of its
    values, n = the pixels of a region), in exact integers (one pass where numpy's reshaped mean and
    std make several)."""
    rh, rw = now.shape[0] // grid, now.shape[1] // grid
    same = np.zeros(grid * grid, np.int64)
    spread = np.zeros(grid * grid, np.int64)
    for gy in range(grid):
        for gx in range(grid):
            total, squares, equal = 0, 0, 0
            for y in range(gy * rh, (gy + 1) * rh):
                for x in range(gx * rw, (gx + 1) * rw):
                    v = np.int64(now[y, x])
                    total += v
                    squares += v * v
                    equal += now[y, x] == last[y, x]
            n = rh * rw
            same[gy * grid + gx] = equal
            spread[gy * grid + gx] = n * squares - total * total
    return same, spread


def read_clip(path: str | Path, limit: int | None = None) -> list[np.ndarray]:
    """The frames of a video file (up to `limit`), as OpenCV decodes them."""
    cap = cv2.VideoCapture(str(path))
    frames = []
    while limit is None or len(frames) < limit:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    cap.release()
    return frames
