"""Plain linear motion: to an absolute pose, by a base-frame offset, or to the home pose."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill
from behaviours.skill_kit.geometry import translated
from behaviours.skill_kit.registry import register


@register
class MoveTo(ProgramSkill):
    NAME = "move_to"
    SUMMARY = "linear move to `pose`, or by `offset` from the current pose"
    PARAMS = {
        "pose": Param("vector", "absolute target pose [x, y, z, rx, ry, rz]", None, "m, rad", length=6),
        "offset": Param("vector", "base-frame offset from the current pose", None, "m", length=3),
        "speed": Param("float", "TCP speed", 0.1, "m/s", min=0.001, max=1.0, device="arm_speed"),
    }
    READS = (keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING)

    @classmethod
    def validate(cls, params) -> None:
        if (params["pose"] is None) == (params["offset"] is None):
            raise ValueError("give exactly one of 'pose' or 'offset'")

    def program(self):
        start = self.pose()
        target = np.array(self.p.pose) if self.p.pose is not None else translated(start, self.p.offset)
        self.feedback_message = f"to {np.round(target[:3], 3).tolist()}"
        fault = yield from self.move(target, self.p.speed)
        if fault:
            return self.fail(fault)
        return Status.SUCCESS
