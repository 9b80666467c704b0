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


# These records are frozen: a state handed out (to the skills, the recorder's batch) never changes.
# Each one is made for every finger on every tick, and a frozen dataclass's own __init__ sets its
# fields one by one through object.__setattr__ (~0.3 us a field, about five times a plain class's
# cost), so each writes its own __init__ that fills the instance's dict in one update.


@dataclass(frozen=True, init=False)
class MarkerField:
    """Tracked markers of one sensor: calibrated origin (N, 2) px, current position (N, 2) px and
    size (N,) px diameter, calibrated size, validity (N,) (tracked this frame), image (W, H)."""

    origin: np.ndarray = field(metadata={"doc": "calibrated marker positions (N, 2)", "unit": "px"})
    position: np.ndarray = field(metadata={"doc": "tracked marker positions this frame (N, 2)", "unit": "px"})
    origin_size: np.ndarray = field(metadata={"doc": "calibrated marker diameters (N,)", "unit": "px"})
    size: np.ndarray = field(metadata={"doc": "marker diameters this frame (N,)", "unit": "px"})
    valid: np.ndarray = field(metadata={"doc": "whether each marker was tracked this frame (N,)"})
    image_size: tuple[int, int] = field(metadata={"doc": "camera image (width, height)", "unit": "px"})

    def __init__(self, origin: np.ndarray | None = None, position: np.ndarray | None = None,
                 origin_size: np.ndarray | None = None, size: np.ndarray | None = None,
                 valid: np.ndarray | None = None, image_size: tuple[int, int] = (320, 240)):
        self.__dict__.update(
            origin=_empty((0, 2)) if origin is None else origin,
            position=_empty((0, 2)) if position is None else position,
            origin_size=_empty((0,)) if origin_size is None else origin_size,
            size=_empty((0,)) if size is None else size,
            valid=_empty((0,), bool) if valid is None else valid,
            image_size=image_size)

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


@dataclass(frozen=True, init=False)
class ObjectInfo:
    """Proximity-vision summary of the object seen through the skin: present, area (fraction of the
    image the object mask covers, 0..1), centroid (normalised image coordinates), orientation (rad,
    principal axis of the mask), cells (object fill per 3x3 cell, 0..1), motion_cells (moving share)."""

    present: bool = field(metadata={"doc": "an object is seen through the skin"})
    area: float = field(metadata={"doc": "share of the image the object mask covers, 0..1"})
    centroid: np.ndarray = field(metadata={"doc": "object centre [x, y], normalised by the image size"})
    orientation: float = field(metadata={"doc": "principal axis of the object mask", "unit": "rad"})
    cells: np.ndarray = field(metadata={"doc": "object fill per cell of a 3x3 grid, 0..1"})
    motion_cells: np.ndarray = field(metadata={"doc": "moving share per cell of a 3x3 grid, 0..1"})

    def __init__(self, present: bool = False, area: float = 0.0, centroid: np.ndarray | None = None,
                 orientation: float = 0.0, cells: np.ndarray | None = None, motion_cells: np.ndarray | None = None):
        self.__dict__.update(
            present=present, area=area, centroid=_empty((2,)) if centroid is None else centroid,
            orientation=orientation, cells=_empty((3, 3)) if cells is None else cells,
            motion_cells=_empty((3, 3)) if motion_cells is None else motion_cells)


@dataclass(frozen=True, init=False)
class TactileState:
    """Everything one FingerVision sensor reports for one frame: stamp (seconds on the cell clock),
    markers, force [shear x, normal, shear z] and torque, object, slip (moving object pixels, share
    of the image: the original mv_s scale), health and its reason."""

    finger: str = field(metadata={"doc": "left or right"})
    stamp: float = field(metadata={"doc": "time of the frame on the cell clock", "unit": "s"})
    markers: MarkerField = field(metadata={"doc": "the tracked marker field"})
    force: np.ndarray = field(metadata={"doc": "[shear x, normal, shear z]", "unit": "px, or N when calibrated"})
    torque: np.ndarray = field(metadata={"doc": "torque about [x, y, z]", "unit": "px, or N m when calibrated"})
    obj: ObjectInfo = field(metadata={"doc": "proximity vision: the object seen through the skin"})
    slip: float = field(metadata={"doc": "moving object pixels, share of the image (the original mv_s scale)"})
    healthy: bool = field(metadata={"doc": "the sensor's frames and markers are usable"})
    health_reason: str = field(metadata={"doc": "why the sensor is unhealthy (empty when healthy)"})

    def __init__(self, finger: str, stamp: float, markers: MarkerField | None = None,
                 force: np.ndarray | None = None, torque: np.ndarray | None = None, obj: ObjectInfo | None = None,
                 slip: float = 0.0, healthy: bool = True, health_reason: str = ""):
        self.__dict__.update(
            finger=finger, stamp=stamp, markers=MarkerField() if markers is None else markers,
            force=_empty((3,)) if force is None else force, torque=_empty((3,)) if torque is None else torque,
            obj=ObjectInfo() if obj is None else obj, slip=slip, healthy=healthy, health_reason=health_reason)
