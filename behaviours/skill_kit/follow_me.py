"""Shared loop of the FollowMe skills: each tick turn what the fingers sense into a TCP velocity
along the selected tool axes, until the duration is over or the object is lost."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill
from behaviours.skill_kit.geometry import rotation
from behaviours.skill_kit.hand import object_area
from perception.state import TactileState

AXES = "xyz"


class TrackingSkill(ProgramSkill):
    """Base of force_track and object_track; subclasses give `start` and `velocity`."""

    COMMON = {
        "duration": Param("float", "follow this long, then stop and succeed; 0 follows until halted", 10.0, "s", min=0.0),
        "axes": Param("str", "tool axes to follow (any of x, y, z; y is the fingers' closing axis)", "xyz"),
        "lost_area": Param("float", "object area below this share of the starting area means it is lost", 0.02, min=0.0, max=1.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT)

    @classmethod
    def validate(cls, params) -> None:
        axes = params["axes"]
        if not axes or set(axes) - set(AXES) or len(set(axes)) != len(axes):
            raise ValueError(f"axes must be a non-empty combination of x, y and z, got {axes!r}")

    @classmethod
    def runs_until_halted(cls, params) -> bool:
        """Bounded by `duration` (or by losing the object), except that 0 follows until halted."""
        return params["duration"] == 0.0

    def start(self):
        """Steps run before following (e.g. a force reference); generator, may yield."""
        return
        yield

    def velocity(self, left: TactileState, right: TactileState) -> np.ndarray:  # pragma: no cover
        """TCP velocity (m/s) along tool [x, y, z] for this tick's tactile states."""
        raise NotImplementedError

    def blind(self, left: TactileState, right: TactileState) -> str:
        """Why the skill cannot follow any more although the object is still held ("" while it can)."""
        return ""

    def program(self):
        arm = self.cell.arm
        mask = np.array([a in self.p.axes for a in AXES], dtype=float)
        area0 = object_area(*self.tactile())
        if area0 <= 0.0:
            return self.fail("no object between the fingers to follow: grasp it first")
        yield from self.start()
        t0 = self.now()
        while self.p.duration == 0.0 or self.now() - t0 < self.p.duration:
            left, right = self.tactile()
            if object_area(left, right) < self.p.lost_area * area0:
                arm.stop()
                return self.fail(f"lost the object after {self.now() - t0:.1f} s: it left the fingers "
                                 "(follow faster: raise the speed gain)")
            fault = self.arm_fault()
            if fault:
                return self.fail(f"arm fault: {fault}")
            blind = self.blind(left, right)
            if blind:
                arm.stop()
                return self.fail(blind)
            v_tool = self.velocity(left, right) * mask
            arm.speed_linear(np.r_[rotation(self.pose()) @ v_tool, 0.0, 0.0, 0.0])
            self.feedback_message = f"following at {np.round(v_tool * 1000, 1).tolist()} mm/s (tool)"
            yield
        arm.stop()
        self.feedback_message = f"followed for {self.p.duration:.1f} s"
        return Status.SUCCESS
