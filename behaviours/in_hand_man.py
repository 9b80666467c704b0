"""InHandMan: the original in-hand pivot (inhand): open a step at a time until the object
slips, close a step while it slips, and finish when it has turned by the target angle,
closing one more step. A turn seen without any slip felt is not a pivot in the fingers (the
view is wrong, or the whole hand turned): the skill then fails instead of succeeding."""

from __future__ import annotations

import math

from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, time_limit
from behaviours.skill_kit.hand import SteadyAngle, object_angle, slip_beyond_marker_flow
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.sensor import sensor_profile


@register
class InHandMan(ProgramSkill):
    NAME = "in_hand_man"
    SUMMARY = "pivot the held object in the fingers by stepping open until it slips (original rule)"
    PARAMS = {
        "target": Param("float", "turn to stop at", 20.0, "deg", min=1.0, max=180.0),
        "step": Param("float", "gripper step", 0.0005, "m", min=1e-5, max=0.005),
        "slip": Param("float", "slip (both fingers) that means the object turns", 0.05, min=0.0),
        "opening": Param("float", "largest opening beyond the starting width", 0.01, "m", min=0.0005, max=0.05),
        "force": Param("float", "gripper force limit", 40.0, "N", min=0.0, device="gripper_force"),
        "max_time": time_limit(20.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.GRIPPER_WIDTH)
    WRITES = (keys.OBJECT_ANGLE,)

    def program(self):
        gripper = self.cell.gripper
        angle = SteadyAngle()
        theta0 = angle.update(object_angle(*self.tactile()))
        if theta0 is None:
            return self.fail("no object seen between the fingers to pivot")
        width0, turned, start, slipped = self.gripper_width(), 0.0, self.now(), False
        speed = self.p.step / self.cell.clock.period
        # The markers moving as the grip opens light up the pipeline's slip too: count only the slip
        # beyond what their motion explains (the sensor profile's slip response).
        profile = sensor_profile(self.cell)
        flow = (profile.slip_flow_gain, profile.slip_flow_saturation)
        before = self.tactile()
        while turned <= self.p.target:
            left, right = self.tactile()
            theta = angle.update(object_angle(left, right))
            if theta is None:
                return self.fail(f"the object fell out after turning {turned:.0f} deg: use a smaller 'step'")
            turned = math.degrees(abs(theta - theta0))
            slip = slip_beyond_marker_flow(left, before[0], *flow) + slip_beyond_marker_flow(right, before[1], *flow)
            before = (left, right)
            slipping = slip >= self.p.slip
            slipped = slipped or slipping
            width = self.gripper_width() + (-self.p.step if slipping else self.p.step)
            if width > width0 + self.p.opening:
                return self.fail(f"opened {self.p.opening * 1000:.1f} mm and the object did not turn: "
                                 "it balances in the grasp, or allow a larger 'opening'")
            if self.now() - start > self.p.max_time:
                gripper.stop()
                return self.fail(f"turned only {turned:.0f} of {self.p.target:.0f} deg in "
                                 f"{self.p.max_time:.0f} s: it slips without turning: raise 'slip', or 'max_time'")
            gripper.move(width, speed, self.p.force)
            self.feedback_message = f"turned {turned:.1f} deg, {'closing' if slipping else 'opening'}"
            yield
        if not slipped:
            gripper.stop()
            return self.fail(f"the view says {turned:.0f} deg but no slip was felt: the object did not "
                             "pivot in the fingers")
        gripper.move(self.gripper_width() - self.p.step, speed, self.p.force)
        yield
        self.write(keys.OBJECT_ANGLE, turned)
        self.feedback_message = f"turned {turned:.1f} deg"
        return Status.SUCCESS
