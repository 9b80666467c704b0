"""The per-finger perception record every skill reads: one `TactileState` per finger per tick.

Units: marker quantities in pixels of the sensor image; force and torque in the units of the
wrench estimator (pixels of marker displacement unless a calibration maps them to newtons);
object centroid normalised by the image size ((W + H) / 2), orientation in radians.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

FINGERS = ("left", "right")


def _empty(shape: tuple[int, ...], dtype=float) -> np.ndarray:
    return np.zeros(shape, dtype=dtype)


@dataclass(frozen=True)
class MarkerField:
    """Tracked markers of one sensor: calibrated origin, current position and size, validity."""

    origin: np.ndarray = field(default_factory=lambda: _empty((0, 2)))  # (N, 2) px
    position: np.ndarray = field(default_factory=lambda: _empty((0, 2)))  # (N, 2) px
    origin_size: np.ndarray = field(default_factory=lambda: _empty((0,)))  # (N,) px diameter
    size: np.ndarray = field(default_factory=lambda: _empty((0,)))  # (N,) px diameter
    valid: np.ndarray = field(default_factory=lambda: _empty((0,), bool))  # (N,) tracked this frame
    image_size: tuple[int, int] = (320, 240)  # (W, H) of the sensor image

    @property
    def displacement(self) -> np.ndarray:
        """(N, 2) marker displacement from its calibrated origin, in pixels."""
        return self.position - self.origin

    @property
    def size_change(self) -> np.ndarray:
        """(N,) growth of the marker diameter over its calibrated size, in pixels."""
        return self.size - self.origin_size

    def __len__(self) -> int:
        return len(self.origin)


@dataclass(frozen=True)
class ObjectInfo:
    """Proximity-vision summary of the object seen through the skin."""

    present: bool = False
    area: float = 0.0  # fraction of the image covered by the object mask, 0..1
    centroid: np.ndarray = field(default_factory=lambda: _empty((2,)))  # normalised image coords
    orientation: float = 0.0  # rad, principal axis of the object mask
    cells: np.ndarray = field(default_factory=lambda: _empty((3, 3)))  # object fill per 3x3 cell, 0..1
    motion_cells: np.ndarray = field(default_factory=lambda: _empty((3, 3)))  # moving object share


@dataclass(frozen=True)
class TactileState:
    """Everything one FingerVision sensor reports for one frame."""

    finger: str
    stamp: float  # seconds on the cell clock
    markers: MarkerField = field(default_factory=MarkerField)
    force: np.ndarray = field(default_factory=lambda: _empty((3,)))  # [shear x, normal, shear z]
    torque: np.ndarray = field(default_factory=lambda: _empty((3,)))
    obj: ObjectInfo = field(default_factory=ObjectInfo)
    slip: float = 0.0  # moving object pixels, share of the image (original mv_s scale)
    healthy: bool = True
    health_reason: str = ""

