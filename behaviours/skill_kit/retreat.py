"""The way out after a release: back away from the standing element along the base frame, then lift
(`place_element`), and the same way finished by a run resumed after it was stopped in between
(`FinishRetreat`, which `for_each_element` ticks before anything else): on a real cell the arm is
still where it stopped, between the fingers' release pose and the lifted pose, and a straight move
home from there can sweep the open fingers through the element it just placed."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import ProgramSkill
from behaviours.skill_kit.geometry import translated

Pose = Sequence[float] | np.ndarray  # [x, y, z, rx, ry, rz], m and rad
ABOVE_M = 0.001  # a TCP higher than the end of the backing-out leg by this is on the lifting leg


def retreat_path(release_pose: Pose, retract: Sequence[float] | np.ndarray, lift: float) -> list[np.ndarray]:
    """The TCP poses of the way out from `release_pose`: backed out by `retract` (base frame, m),
    then lifted by `lift` (m)."""
    backed = translated(release_pose, retract)
    return [backed, translated(backed, [0.0, 0.0, lift])]


def remaining_path(path: Sequence[Pose], tcp: Pose) -> list[np.ndarray]:
    """The part of a way out (`retreat_path`) still ahead of a TCP stopped on it: all of it while
    the TCP is not above the backed-out pose (it stopped on the first, level leg: going on to the
    backed-out pose continues that straight line), else the lifting leg's end only."""
    poses = [np.asarray(p, float) for p in path]
    if len(poses) > 1 and tcp[2] > poses[0][2] + ABOVE_M:
        return poses[1:]
    return poses


class FinishRetreat(ProgramSkill):
    """The rest of an element's way out, from where the arm stands when a resumed run starts: the
    poses of `remaining_path` at `speed`. Not a tree node of its own: `for_each_element` ticks it
    before the first element of a session whose last one was placed but not backed out of."""

    NAME = "finish_retreat"
    SUMMARY = "finish the way out of a placed element, after a resume"
    READS = (keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING)

    def __init__(self, name: str, element: str, path: Sequence[Pose], speed: float):
        super().__init__(name, resolved={})
        self.element, self.path, self.speed = element, [np.asarray(p, float) for p in path], float(speed)

    def program(self):
        self.feedback_message = f"finishing the way out of {self.element}"
        for target in remaining_path(self.path, self.pose()):
            fault = yield from self.move(target, self.speed)
            if fault:
                return self.fail(f"the way out of {self.element}: {fault}")
        self.feedback_message = f"backed out of {self.element}"
        return Status.SUCCESS
