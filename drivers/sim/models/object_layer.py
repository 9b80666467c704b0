"""The object seen through the skin of the synthetic FingerVision camera, drawn on its bounding box.

The object is a rectangle with the requested area share, centroid and orientation (the
proximity-vision convention of `perception.state.ObjectInfo`), painted with a smooth seeded
random texture that slides along its long axis as the object slips. Only the rectangle's bounding
box is computed: a soft (1 px edge) coverage and the texture sampled by one affine warp.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from perception.state import ObjectInfo

OBJECT_BGR = (40.0, 120.0, 235.0)  # bright orange, as the thesis painted its test objects
TEXTURE_SIDE = 256  # px, side of the (wrapped) object texture


def object_info_from_mask(mask: np.ndarray, corner: tuple[int, int] = (0, 0),
                          image_size: tuple[int, int] | None = None) -> ObjectInfo:
    """Area share, centroid and orientation of a boolean mask, in the proximity-vision convention;
    `mask` may be the part of an (W, H) `image_size` mask whose top-left pixel is `corner` (x, y)."""
    w, h = image_size or mask.shape[::-1]
    m = cv2.moments(mask.view(np.uint8), binaryImage=True)
    if m["m00"] == 0:
        return ObjectInfo()
    div = (w + h) / 2.0
    centroid = np.array([(m["m10"] / m["m00"] + corner[0] - w / 2.0) / div,
                         (m["m01"] / m["m00"] + corner[1] - h / 2.0) / div])
    angle = 0.5 * np.arctan2(2.0 * m["mu11"], m["mu20"] - m["mu02"])
    return ObjectInfo(True, m["m00"] / float(w * h), centroid, float(angle))


@dataclass(frozen=True)
class ObjectPatch:
    """The object on its bounding box `box` (y0, y1, x0, x1): coverage and colour."""

    box: tuple[int, int, int, int]
    soft: np.ndarray  # (h, w) float32 share of each pixel the object covers, inside the window
    colour: np.ndarray  # (h, w, 3) uint8 textured object colour


@dataclass(frozen=True)
class Placement:
    """Where the object rectangle lies in the image (px) and how far its texture has slid."""

    centre: tuple[float, float]
    length: float
    width: float
    angle: float
    shift: float

    def moved(self, other: Placement | None, tolerance: float) -> bool:
        """Whether any edge or texture point moves more than `tolerance` px from `other`."""
        if other is None:
            return True
        reach = max(self.length, self.width) / 2.0
        return max(abs(self.centre[0] - other.centre[0]), abs(self.centre[1] - other.centre[1]),
                   abs(self.length - other.length), abs(self.width - other.width),
                   abs(self.angle - other.angle) * reach, abs(self.shift - other.shift)) > tolerance


class ObjectLayer:
    """Draws the textured object rectangle for a sensor image with a soft round `window` (H, W)."""

    def __init__(self, rng: np.random.Generator, window: np.ndarray, colour: tuple[float, float, float] = OBJECT_BGR):
        self.window = window
        h, w = window.shape
        self.image_size = (w, h)
        noise = rng.standard_normal((TEXTURE_SIDE, TEXTURE_SIDE)).astype(np.float32)
        tex = cv2.GaussianBlur(noise, (0, 0), 2.0)
        texture = 1.0 + 0.25 * tex / tex.std()  # smooth, non-periodic, mean 1
        self._colour = cv2.convertScaleAbs(texture[:, :, None] * np.asarray(colour, np.float32))

    def place(self, obj: ObjectInfo, shift: float) -> Placement:
        """The rectangle with the object's area share and pose; `shift` px of texture slide."""
        w, h = self.image_size
        div = (w + h) / 2.0
        area = max(float(obj.area), 1e-4) * w * h
        length = math.sqrt(area * 1.6)
        cx, cy = (float(c) for c in obj.centroid)
        return Placement((w / 2.0 + cx * div, h / 2.0 + cy * div), length, area / length,
                         float(obj.orientation), float(shift))

    def draw(self, place: Placement) -> ObjectPatch | None:
        """The object's coverage and colour on its bounding box (None when it is off the image)."""
        w, h = self.image_size
        cos, sin = np.cos(place.angle), np.sin(place.angle)
        cx, cy = place.centre
        reach_x = (abs(cos) * place.length + abs(sin) * place.width) / 2.0 + 1.0
        reach_y = (abs(sin) * place.length + abs(cos) * place.width) / 2.0 + 1.0
        x0, x1 = max(0, int(np.floor(cx - reach_x))), min(w, int(np.ceil(cx + reach_x)) + 1)
        y0, y1 = max(0, int(np.floor(cy - reach_y))), min(h, int(np.ceil(cy + reach_y)) + 1)
        if x0 >= x1 or y0 >= y1:
            return None
        xs = np.arange(x0, x1, dtype=np.float32) - np.float32(cx)
        ys = np.arange(y0, y1, dtype=np.float32)[:, None] - np.float32(cy)
        if place.angle == 0.0:  # (u, v) = (x, y): one row and one column
            u, v = xs, ys
        else:
            u = xs * np.float32(cos) + ys * np.float32(sin)  # along the object's long axis
            v = ys * np.float32(cos) - xs * np.float32(sin)
        # Coverage: clip(min(length / 2 - |u|, width / 2 - |v|) + 0.5, 0, 1), inside the window.
        cover_u = np.clip(np.float32(place.length / 2 + 0.5) - np.abs(u), 0.0, 1.0)
        cover_v = np.clip(np.float32(place.width / 2 + 0.5) - np.abs(v), 0.0, 1.0)
        soft = np.minimum(cover_u, cover_v) * self.window[y0:y1, x0:x1]
        # The texture at (u - shift, v), as one affine map from the box's pixels.
        half = TEXTURE_SIDE / 2.0
        warp = np.array([[cos, sin, (x0 - cx) * cos + (y0 - cy) * sin - place.shift + half],
                         [-sin, cos, (y0 - cy) * cos - (x0 - cx) * sin + half]])
        colour = cv2.warpAffine(self._colour, warp, (x1 - x0, y1 - y0),
                                flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_WRAP)
        return ObjectPatch((y0, y1, x0, x1), soft, colour)
