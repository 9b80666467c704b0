"""Bring a held element upright by turning the wrist about the fingers' closing axis, watching
for slip in the grasp all the way."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill
from behaviours.skill_kit.geometry import rotated_about_tool
from behaviours.skill_kit.registry import register


@register
class RotateElement(ProgramSkill):
    NAME = "rotate_element"
    SUMMARY = "turn the held element about the finger axis (upright by default); fail on slip"
    PARAMS = {
        "angle": Param("float", "rotation about the tool y axis", 90.0, "deg", min=-180.0, max=180.0),
        "max_slip": Param("float", "slip that aborts the rotation", 0.05, min=0.0),
        "ground_clearance": Param("float", "least height of the element's swept end above the ground", 0.01, "m", min=0.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.ELEMENT_LENGTH, keys.ROBOT_POSE, keys.ROBOT_FAULT,
             keys.ROBOT_MOVING)
    NEEDS = ("elements",)
    OPTIONAL_READS = (keys.ELEMENT_LENGTH,)  # measured by vis_scan; unknown: no ground check

    def program(self):
        start = self.pose()
        length = self.read(keys.ELEMENT_LENGTH)
        if length is not None and start[2] - length / 2.0 < self.p.ground_clearance:
            return self.fail(f"lift first: a {length:.3f} m element turned at z = {start[2]:.3f} m "
                             f"would hit the ground (needs z >= {length / 2 + self.p.ground_clearance:.3f} m)")
        target = rotated_about_tool(start, 1, np.radians(self.p.angle))
        fault = yield from self.move(target, 0.1, watch=self._slipping)
        if fault:
            return self.fail(fault)
        self.feedback_message = f"rotated {self.p.angle:.0f} deg"
        return Status.SUCCESS

    def _slipping(self) -> str | None:
        left, right = self.tactile()
        slip = max(left.slip, right.slip)
        if slip > self.p.max_slip:
            return f"element slipping in the grasp (slip {slip:.2f} > {self.p.max_slip})"
        return None
