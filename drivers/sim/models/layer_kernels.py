"""The synthetic FingerVision camera's per-rectangle work, compiled (numba): the rectangles the markers
are drawn on, and lighting a frame (gain, gradient, colour cast, glare) on the rectangles that
changed only.

The lighting does, pixel by pixel, the float32 operations the whole-image numpy drawing did, in the
same order (v * light * cast, then v + glare * (255 - v), rounded half to even and saturated as
`cv2.convertScaleAbs` does): a frame lit on its changed rectangles equals one lit whole, to the bit
(`tests/perception/test_fv_sim_camera.py::test_dirty_rectangles_equal_a_full_render`).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, inline="always")
def _lit(value, light, cast, glare):  # pragma: no cover - compiled
    """One channel of one pixel (uint8) under the lighting, float32 as the numpy drawing computed it."""
    v = np.float32(value) * light
    v = v * cast
    return v + glare * (np.float32(255.0) - v)


@njit(cache=True, nogil=True, error_model="numpy")
def light_rects(src, dst, rects, light, cast, glare):  # pragma: no cover - compiled
    """`dst` (H, W, 3) uint8 = `src` lit, on the rectangles `rects` (K, 4: y0, y1, x0, x1) only:
    light (H, W) float32 gain, cast (3,) float32 B, G, R gains, glare (H, W) float32 (1.2 x the
    glare mask), rounded half to even and saturated to 0..255."""
    top = np.float32(255.0)
    for k in range(len(rects)):
        y0, y1, x0, x1 = rects[k, 0], rects[k, 1], rects[k, 2], rects[k, 3]
        for y in range(y0, y1):
            for x in range(x0, x1):
                gain, shine = light[y, x], glare[y, x]
                for ch in range(3):
                    v = abs(np.rint(_lit(src[y, x, ch], gain, cast[ch], shine)))
                    dst[y, x, ch] = np.uint8(min(v, top))


@njit(cache=True, nogil=True, error_model="numpy")
def light_float(src, dst, light, cast, glare):  # pragma: no cover - compiled
    """`dst` (H, W, 3) float32 = `src` lit, unrounded (for a blur to follow)."""
    for y in range(src.shape[0]):
        for x in range(src.shape[1]):
            gain, shine = light[y, x], glare[y, x]
            for ch in range(3):
                dst[y, x, ch] = _lit(src[y, x, ch], gain, cast[ch], shine)


@njit(cache=True, nogil=True)
def patch_boxes(position, reach, width, height):  # pragma: no cover - compiled
    """(N, 4) rectangles (y0, y1, x0, x1) of the (2 reach + 2) px square patches starting `reach` px
    before the pixel holding each of the `position` (N, 2) px (x, y), clipped to the image."""
    boxes = np.empty((len(position), 4), np.int64)
    for i in range(len(position)):
        x, y = np.int64(np.floor(position[i, 0])), np.int64(np.floor(position[i, 1]))
        boxes[i, 0] = min(max(y - reach, 0), height)
        boxes[i, 1] = min(max(y + reach + 2, 0), height)
        boxes[i, 2] = min(max(x - reach, 0), width)
        boxes[i, 3] = min(max(x + reach + 2, 0), width)
    return boxes
