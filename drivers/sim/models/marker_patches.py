"""Marker discs of the synthetic FingerVision camera, drawn on small patches around each marker.

A marker is a black disc squashed radially towards the rim of the round sensor window (the skin
curves away from the camera there). Each pixel of a square patch around a marker's centre gets the
share of it the disc covers (a ~1 px linear edge), so the darkness-weighted centre of the drawn
marker is its true centre to a few hundredths of a pixel. The covers are computed in float32 and
blended over the image beneath, marker by marker, in one compiled pass (numba).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from drivers.sim.models.layer_kernels import patch_boxes

MARKER_GREY = 18.0  # marker core brightness before lighting


@dataclass(frozen=True)
class MarkerPainter:
    """Draws the markers of one sensor window (centre and radius in px)."""

    image_size: tuple[int, int]
    centre: np.ndarray
    window_radius: float
    foreshortening: float  # radial squash of the markers at the window rim

    def squash(self, position: np.ndarray) -> np.ndarray:
        """(N,) squash of each marker: its radius along the radial direction is its radius across times
        squash^2 (1 at the window centre, 1 - foreshortening at the rim), its mean radius times squash."""
        rel = position - self.centre
        rho = np.hypot(rel[:, 0], rel[:, 1])
        return np.sqrt(1.0 - self.foreshortening * np.minimum(rho / self.window_radius, 1.0) ** 2)

    def paint(self, target: np.ndarray, position: np.ndarray, size: np.ndarray,
              squash: np.ndarray | None = None) -> np.ndarray:
        """Draw markers centred at `position` (N, 2) px with diameters `size` (N,) px over the
        (H, W, 3) uint8 image `target`, in place (`squash`: theirs, if the caller has it already).
        Returns (N, 4) int64 rectangles (y0, y1, x0, x1), clipped to the image, holding every pixel
        written for each marker (its patch): outside them `target` is left as it was."""
        position = np.asarray(position, float).reshape(-1, 2)
        if not len(position):
            return np.zeros((0, 4), np.int64)
        reach = self._reach(size)
        _paint(target, position, np.asarray(size, float), self.squash(position) if squash is None else squash,
               self.centre.astype(float), reach, MARKER_GREY)
        return patch_boxes(position, reach, *self.image_size)

    def _reach(self, size: np.ndarray) -> int:
        """Half the side of the markers' patches, px. Pixels up to 0.5 px (in (u, v) of `_paint`) beyond
        the rim are covered in part: at most a_t + 0.5 / sqrt(1 - foreshortening) px from the centre;
        the patch starts at the pixel holding the centre, so it reaches one more pixel on the far side."""
        return int(np.ceil(max(float(np.max(size)) / 2.0, 1.0) + 0.5 / np.sqrt(1.0 - self.foreshortening)))


@njit(cache=True, nogil=True, error_model="numpy")
def _paint(target, position, size, squash, centre, reach, grey):  # pragma: no cover - compiled
    """Each marker's disc over `target`: cover = clip(0.5 + mean_r - |(u, v)|, 0, 1) on its patch,
    with (u, v) the pixel offset along and across the radial direction scaled so that the rim is at
    |(u, v)| == mean_r (mean_r = a_t squash, a_t the radius across); pixel = beneath (1 - cover) +
    grey cover. Float32 as the numpy drawing was, the root taken in float64 and rounded once."""
    height, width = target.shape[0], target.shape[1]
    f32 = np.float32
    for i in range(len(position)):
        rx, ry = position[i, 0] - centre[0], position[i, 1] - centre[1]
        rho = math.hypot(rx, ry)
        if rho > 1e-6:
            ux, uy = rx / max(rho, 1e-6), ry / max(rho, 1e-6)
        else:
            ux, uy = 1.0, 0.0
        s = squash[i]
        c0, c1, c2, c3 = f32(ux / s), f32(uy / s), f32(ux * s), f32(uy * s)
        rim = f32(size[i] / 2.0 * s - 0.5)
        x0, y0 = math.floor(position[i, 0]), math.floor(position[i, 1])
        fx, fy = f32(position[i, 0] - x0), f32(position[i, 1] - y0)
        for r in range(-reach, reach + 2):
            y = int(y0) + r
            if y < 0 or y >= height:
                continue
            dy = f32(r) - fy
            for c in range(-reach, reach + 2):
                x = int(x0) + c
                if x < 0 or x >= width:
                    continue
                dx = f32(c) - fx
                u = dx * c0 + dy * c1
                v = dy * c2 - dx * c3
                keep = f32(math.sqrt(float(u) * float(u) + float(v) * float(v))) - rim
                if keep >= f32(1.0):  # outside the disc: the pixel would be written as it is
                    continue
                keep = max(keep, f32(0.0))
                ink = keep * f32(-grey) + f32(grey + 0.5)
                for ch in range(3):
                    target[y, x, ch] = np.uint8(f32(target[y, x, ch]) * keep + ink)
