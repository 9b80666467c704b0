"""Lower the held element until FingerVision feels the ground, |f_t - f_0| > eps, or the arm's own
force readback changes by more than `force_eps` N (contact is then felt even if the fingertip
stream froze)."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, magnitude, summed_force
from behaviours.skill_kit.registry import register


@register
class DescendUntilContact(ProgramSkill):
    NAME = "descend_until_contact"
    SUMMARY = "move down until the finger force changes by more than eps"
    PARAMS = {
        "speed": Param("float", "descent speed", 0.01, "m/s", min=1e-4, max=0.1),
        "eps": Param("float", "force change that means contact", 0.5, "px", min=0.0),
        "max_travel": Param("float", "give up after descending this far (or at the workspace box's "
                            "floor, whichever comes first)", 0.15, "m", min=0.0, max=1.0),
        "reference_ticks": Param("int", "ticks averaged for the reference force f_0", 5, min=1),
        "force_eps": Param("float", "change of the arm's measured TCP force that also means contact "
                           "(0: fingertips only)", 2.0, "N", min=0.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_WRENCH)
    WRITES = (keys.CONTACT_POSE,)

    def program(self):
        arm = self.cell.arm
        f0 = yield from self.mean_force(self.p.reference_ticks)
        w0 = np.array(self.read(keys.ROBOT_WRENCH)[:3], dtype=float)
        start_z = self.pose()[2]
        arm.speed_linear(np.array([0.0, 0.0, -self.p.speed, 0.0, 0.0, 0.0]))
        while True:
            yield
            left, right = self.tactile()
            change = magnitude(summed_force(left, right) - f0)
            felt = magnitude(self.read(keys.ROBOT_WRENCH)[:3] - w0)
            pose = self.pose()
            travelled = start_z - pose[2]
            self.feedback_message = (f"down {travelled * 1000:.1f} mm, |f - f0| = {change:.2f} px, "
                                     f"arm force change {felt:.2f} N")
            if change > self.p.eps or 0.0 < self.p.force_eps < felt:
                arm.stop()
                self.write(keys.CONTACT_POSE, pose)
                return Status.SUCCESS
            fault = self.arm_fault()
            if fault:
                return self.fail(f"arm fault: {fault}")
            if travelled > self.p.max_travel:
                arm.stop()
                return self.fail(f"no contact within {self.p.max_travel} m of descent")
            held = self.held_at_box()
            if held:
                arm.stop()
                return self.fail(f"no contact after {travelled * 1000:.0f} mm of descent, at the workspace "
                                 f"box's {held}: the safety layer stops the arm there")
