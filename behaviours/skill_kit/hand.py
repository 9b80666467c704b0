"""What the two fingertips feel, expressed in tool axes: the force and torque a held object
puts on the hand, the object's in-hand angle, and slip.

Finger conventions (perception/wrench.py): index 1 of each finger's force is its normal, so the
sum over both fingers cancels the grip squeeze and keeps the difference of the normal loads;
image x runs along tool x (mirrored on the left finger), image y along tool z.
"""

from __future__ import annotations

import statistics
from collections import deque

import numpy as np

from perception.state import ObjectInfo, TactileState, background_match_of


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


def slip_beyond_marker_flow(now: TactileState, before: TactileState, gain: float, saturation: float) -> float:
    """One finger's slip beyond what its markers' own motion explains: the pipeline's slip is image
    motion over the object, so markers moving under a changing load light it up as much as the
    object sliding over them. Explained: `gain` x object area x the markers' mean motion since
    `before` (px/frame, capped at `saturation`); what stays is the object moving against them.
    Nothing is explained when no marker was tracked in both states or the two fields differ (a new
    calibration between them)."""
    a, b = now.markers, before.markers
    if not now.obj.present or a.position.shape != b.position.shape or not len(a.valid) == len(b.valid) == len(a):
        return now.slip
    from behaviours.skill_kit.marker_motion import tracked_motion  # numba: loaded by a run, not by `fvtree validate`

    tracked, total = tracked_motion(a.position, b.position, a.valid, b.valid)
    if not tracked:
        return now.slip
    return max(0.0, now.slip - gain * now.obj.area * min(total / tracked, saturation))


def warm_up() -> None:
    """Load the compiled marker motion now (skills that use it call this when set up; see
    `perception.wrench.warm_up`)."""
    from behaviours.skill_kit.marker_motion import tracked_motion

    position, valid = np.zeros((1, 2)), np.ones(1, bool)
    tracked_motion(position, position, valid, valid)


class SteadyAngle:
    """The object's in-hand angle as the median of the last `ticks` views: the pipeline's angle
    is noisy (about 1 deg), so a turn judged on single frames stops early on a noisy one."""

    def __init__(self, ticks: int = 5):
        self.ticks = ticks
        self._seen: deque[float] = deque(maxlen=ticks)

    def update(self, angle: float | None) -> float | None:
        """Add this tick's angle (None: the object is not seen, and the history is dropped)."""
        if angle is None:
            self._seen.clear()
            return None
        self._seen.append(angle)
        return statistics.median(self._seen)  # the same value as np.median, without its overhead on a few floats


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


def still_seen(area: float, held_area: float, gone_share: float) -> bool:
    """Whether an object seen with `held_area` while held is still between the fingers at `area`:
    above `gone_share` of that area. Not `area > 0`: the proximity mask keeps a few pixels of the
    background whose colours match the object's model after the object has left (about 1 % of
    the image, where a held object covers 20-30 %)."""
    return area > gone_share * held_area if held_area > 0.0 else area > 0.0


def grip_squeeze(left: TactileState, right: TactileState) -> float:
    """The squeeze both pads feel along the closing axis (px): the common part of their normal
    loads, which the hand force (their difference) cancels."""
    return 0.5 * float(left.force[1] - right.force[1])


def false_object(states: tuple[TactileState, ...], areas: dict[str, float], max_share: float) -> str:
    """Why the object a camera shows is not the object ('' when it is): the first state whose pipeline
    warns that its colour model takes more of the empty view for the object than `max_share` of the
    object's own seen area (`areas`, per finger: glare, a background of the object's colour)."""
    for state in states:
        match, area = background_match_of(state.health_reason), areas[state.finger]
        if match > max_share * area:
            return (f"the {state.finger} camera cannot tell the object from its background (its colour model "
                    f"takes {match:.1%} of the empty view for it, the object covers {area:.1%}): the object's "
                    "position and orientation it shows are not the object's")
    return ""
