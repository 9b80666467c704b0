"""What the two fingertips feel, expressed in tool axes: the force and torque a held object
puts on the hand, the object's in-hand angle, and slip.

Finger conventions (perception/wrench.py): index 1 of each finger's force is its normal, so the
sum over both fingers cancels the grip squeeze and keeps the difference of the normal loads;
image x runs along tool x (mirrored on the left finger), image y along tool z.
"""

from __future__ import annotations

import numpy as np

from perception.state import ObjectInfo, TactileState


def hand_force(left: TactileState, right: TactileState) -> np.ndarray:
    """Force the object puts on the hand along tool [x, y, z] (px of marker motion)."""
    s = left.force + right.force
    return np.array([s[0], -s[1], -s[2]])


def hand_torque(left: TactileState, right: TactileState) -> float:
    """Torque the object puts on the hand about tool y, the fingers' closing axis (px)."""
    return -float(left.torque[1] + right.torque[1])


def total_slip(left: TactileState, right: TactileState) -> float:
    """Slip summed over both fingers, as the original behaviours use it."""
    return left.slip + right.slip


def watched_view(left: TactileState, right: TactileState) -> tuple[ObjectInfo, float]:
    """The view of the finger that sees more of the object, and its side (-1 left, +1 right)."""
    return (left.obj, -1.0) if left.obj.area > right.obj.area else (right.obj, 1.0)


def object_angle(left: TactileState, right: TactileState) -> float | None:
    """The object's orientation in the tool x-z plane (rad) from the finger seeing more of it;
    None when neither finger sees it."""
    view, side = watched_view(left, right)
    return side * view.orientation if view.present else None


def object_area(left: TactileState, right: TactileState) -> float:
    return max(left.obj.area, right.obj.area)


def grip_squeeze(left: TactileState, right: TactileState) -> float:
    """The squeeze both pads feel along the closing axis (px): the common part of their normal
    loads, which the hand force (their difference) cancels."""
    return 0.5 * float(left.force[1] - right.force[1])
