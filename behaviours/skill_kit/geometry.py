"""Pose arithmetic on UR 6-vectors [x, y, z, rx, ry, rz] (rotation vectors)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # scipy loads with the first pose turned, not with every import of the skill kit
    from scipy.spatial.transform import Rotation


_Rotation: type[Rotation] | None = None  # scipy's Rotation once loaded (`warm_up` or the first pose turned)


def warm_up() -> None:
    """Load scipy's rotations now: a skill that turns poses calls this in its `setup`, so that the import
    (~0.1-0.2 s, ~5 % of a whole signals-mode assembly run's ticks) happens before the run, not on the
    tick that first turns a pose."""
    global _Rotation
    if _Rotation is None:
        from scipy.spatial.transform import Rotation

        _Rotation = Rotation


def _rotation(rotvec) -> Rotation:
    """scipy's Rotation of a rotation vector (no import statement per call once loaded)."""
    if _Rotation is None:
        warm_up()
    assert _Rotation is not None
    return _Rotation.from_rotvec(rotvec)


def rotation(pose) -> np.ndarray:
    """3x3 rotation matrix of a pose; column i is tool axis i in the base frame."""
    return _rotation(np.asarray(pose, float)[3:]).as_matrix()


def translated(pose, offset) -> np.ndarray:
    """The pose moved by a base-frame offset [dx, dy, dz]."""
    out = np.array(pose, dtype=float)
    out[:3] += np.asarray(offset, float)
    return out


def rotated_about_tool(pose, axis: int, angle: float) -> np.ndarray:
    """The pose turned by `angle` rad about its own tool axis `axis` (0 x, 1 y, 2 z)."""
    rotvec = np.zeros(3)
    rotvec[axis] = angle
    turned = _rotation(np.asarray(pose, float)[3:]) * _rotation(rotvec)
    return np.concatenate([np.asarray(pose, float)[:3], turned.as_rotvec()])


def angle_between(pose_a, pose_b) -> float:
    """Rotation angle (rad) between the orientations of two poses."""
    rel = _rotation(np.asarray(pose_a, float)[3:]).inv() * _rotation(
        np.asarray(pose_b, float)[3:])
    return float(rel.magnitude())


def top_down_grasp(element_pose) -> np.ndarray:
    """TCP pose at an element's centre with the tool pointing down and the fingers closing
    across the element's width (tool = element frame turned half a turn about its x axis)."""
    p = np.asarray(element_pose, float)
    turned = _rotation(p[3:]) * _rotation([np.pi, 0.0, 0.0])
    return np.concatenate([p[:3], turned.as_rotvec()])
