"""Marker discs of the synthetic FingerVision camera, computed on small patches around each marker.

A marker is a black disc squashed radially towards the rim of the round sensor window (the skin
curves away from the camera there). Each pixel of a square patch around a marker's centre gets the
share of it the disc covers (a ~1 px linear edge), so the darkness-weighted centre of the drawn
marker is its true centre to a few hundredths of a pixel. All markers are computed at once in
float32 on their patches only, and blended over the image beneath them by flat pixel index.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

MARKER_GREY = 18.0  # marker core brightness before lighting


@dataclass(frozen=True)
class MarkerPatches:
    """Where and how much the markers cover: one (P, P) patch per marker."""

    index: np.ndarray  # (3, N, P, P) index of each patch pixel's channel in the flattened (H, W, 3) image
    keep: np.ndarray  # (N, P, P) float32 share of each pixel still showing the image beneath
    ink: np.ndarray  # (N, P, P) float32 marker grey each pixel gets, plus 0.5 to round
    diameter: np.ndarray  # (N,) px, equivalent diameter of each (foreshortened) marker


@dataclass(frozen=True)
class MarkerPainter:
    """Computes and draws the markers of one sensor window (centre and radius in px)."""

    image_size: tuple[int, int]
    centre: np.ndarray
    window_radius: float
    foreshortening: float  # radial squash of the markers at the window rim

    def patches(self, position: np.ndarray, size: np.ndarray) -> MarkerPatches:
        """Patches of markers centred at `position` (N, 2) px with diameters `size` (N,) px."""
        rel = position - self.centre
        rho = np.hypot(rel[:, 0], rel[:, 1])
        radial = np.where(rho[:, None] > 1e-6, rel / np.maximum(rho, 1e-6)[:, None], [1.0, 0.0])
        # Radii across (a_t) and along (a_r = a_t squash^2) the radial direction; mean_r = a_t squash.
        squash = np.sqrt(1.0 - self.foreshortening * np.minimum(rho / self.window_radius, 1.0) ** 2)
        a_t = size / 2.0
        mean_r = a_t * squash
        # Pixels up to 0.5 px (in (u, v) below) beyond the rim are covered in part: at most
        # a_t + 0.5 / sqrt(1 - foreshortening) px from the centre; the patch starts at the pixel
        # holding the centre, so it reaches one more pixel on the far side.
        reach = int(np.ceil(a_t.max(initial=1.0) + 0.5 / np.sqrt(1.0 - self.foreshortening)))
        off = np.arange(-reach, reach + 2, dtype=np.float32)
        corner = np.floor(position)
        frac = (position - corner).astype(np.float32)
        dx = off - frac[:, 0, None]  # (N, P)
        dy = off - frac[:, 1, None]
        # (u, v): along and across the radial direction, scaled so that the disc rim is at
        # hypot(u, v) == mean_r; the cover is then a 1 px ramp around the rim.
        c = np.stack([radial[:, 0] / squash, radial[:, 1] / squash, radial[:, 0] * squash,
                      radial[:, 1] * squash]).astype(np.float32)[:, :, None, None]
        u = dx[:, None, :] * c[0] + dy[:, :, None] * c[1]
        v = dy[:, :, None] * c[2] - dx[:, None, :] * c[3]
        keep = _hypot32(u, v)  # becomes 1 - cover, cover = clip(0.5 + mean_r - hypot, 0, 1)
        keep -= (mean_r - 0.5).astype(np.float32)[:, None, None]
        np.clip(keep, 0.0, 1.0, out=keep)
        index, outside = self._index(corner.astype(int), reach)
        if outside is not None:
            keep[outside] = 1.0
        ink = keep * np.float32(-MARKER_GREY)
        ink += np.float32(MARKER_GREY + 0.5)
        return MarkerPatches(index, keep, ink, 2.0 * mean_r)

    def _index(self, corner: np.ndarray, reach: int) -> tuple[np.ndarray, np.ndarray | None]:
        """Flat channel indices of the patches from `corner` (N, 2) - `reach` to `corner` + `reach`
        + 1, and which patch pixels fall outside the image (None when all are inside)."""
        w, h = self.image_size
        if corner.min(initial=reach) >= reach and corner[:, 0].max(initial=0) + reach + 1 < w \
                and corner[:, 1].max(initial=0) + reach + 1 < h:
            start = (corner[:, 1] * w + corner[:, 0]) * 3
            return _patch_offsets(reach, w) + start[:, None, None], None
        off = np.arange(-reach, reach + 2)
        channel = np.arange(3)[:, None, None, None]
        gx = corner[:, 0, None, None] + off[None, None, :]
        gy = corner[:, 1, None, None] + off[None, :, None]
        outside = (gx < 0) | (gx >= w) | (gy < 0) | (gy >= h)
        flat = np.clip(gy, 0, h - 1) * w + np.clip(gx, 0, w - 1)
        return channel + 3 * flat, outside

    @staticmethod
    def paint(target: np.ndarray, patches: MarkerPatches) -> None:
        """Draw the markers over the (H, W, 3) uint8 image `target`, in place."""
        flat = target.reshape(-1)
        drawn = flat[patches.index] * patches.keep
        drawn += patches.ink
        flat[patches.index] = drawn.astype(np.uint8)


def _hypot32(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """np.hypot of float32 arrays, the same values at half the time: each square and their sum are
    taken in float64 (exact squares, one rounding), the root rounded once to float32, as the C
    library's hypotf does (checked bit for bit on millions of values); numpy's float32 hypot goes
    through that function per element."""
    sq = u.astype(np.float64)
    sq *= sq
    vv = v.astype(np.float64)
    vv *= vv
    sq += vv
    np.sqrt(sq, out=sq)
    return sq.astype(np.float32)


@functools.lru_cache(maxsize=8)
def _patch_offsets(reach: int, width: int) -> np.ndarray:
    """(3, 1, P, P) flat channel index of each patch pixel relative to the patch's corner pixel, in an
    image `width` px wide: the same for every marker, so computed once per patch size."""
    off = np.arange(-reach, reach + 2)
    index = np.arange(3)[:, None, None, None] + 3 * (off[:, None] * width + off[None, :])
    index.flags.writeable = False
    return index
