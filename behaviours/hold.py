"""Hold: keep a grasped object from slipping out by closing the gripper one step whenever the
slip summed over both fingers exceeds a threshold (the FingerVision Hold rule). When the fingers
no longer close (the gripper is at its force limit) and the object still slips on `limit_steps`
tightening steps in a row, holding has failed: the skill says so instead of waiting for the drop."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, gone_share
from behaviours.skill_kit.hand import object_area, still_seen, total_slip
from behaviours.skill_kit.registry import register


@register
class Hold(ProgramSkill):
    NAME = "hold"
    SUMMARY = "keep a grasped object: close one step whenever slip exceeds a threshold"
    PARAMS = {
        "slip": Param("float", "slip (both fingers) that triggers a tightening step", 0.06, min=0.0),
        "step": Param("float", "gripper closing step per trigger", 0.0005, "m", min=1e-5, max=0.005),
        "force": Param("float", "gripper force limit while tightening", 40.0, "N", min=0.0, device="gripper_force"),
        "duration": Param("float", "hold this long, then succeed; 0 holds until halted", 5.0, "s", min=0.0),
        "min_width": Param("float", "width at which tightening gives up", 0.002, "m", min=0.0, device="gripper_width"),
        "gone_share": gone_share(),
        "limit_steps": Param("int", "tightening steps in a row that do not close the fingers (force limit) "
                             "before giving up on a slipping object", 10, min=1),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.GRIPPER_WIDTH)

    @classmethod
    def runs_until_halted(cls, params) -> bool:
        """Bounded by `duration` (or by losing the object), except that 0 holds until halted."""
        return params["duration"] == 0.0

    def program(self):
        gripper = self.cell.gripper
        start, steps, stuck, last_width = self.now(), 0, 0, None
        held_area = object_area(*self.tactile())
        if held_area <= 0.0:
            return self.fail("nothing between the fingers to hold: grasp the object first")
        while self.p.duration == 0.0 or self.now() - start < self.p.duration:
            left, right = self.tactile()
            if not still_seen(object_area(left, right), held_area, self.p.gone_share):
                return self.fail(f"the object left the grip after {steps} tightening steps: "
                                 "raise 'force', or lower 'slip' to react sooner")
            slip = total_slip(left, right)
            if slip > self.p.slip:
                now_width = self.gripper_width()
                stuck = stuck + 1 if last_width is not None and now_width > last_width - self.p.step / 2 else 0
                if stuck >= self.p.limit_steps:
                    gripper.stop()
                    return self.fail(f"the object keeps slipping with the gripper at its force limit "
                                     f"({self.p.force:.0f} N, {now_width * 1000:.1f} mm): it is too heavy to hold")
                width = now_width - self.p.step
                if width < self.p.min_width:
                    return self.fail(f"closed to {now_width * 1000:.1f} mm and the object still slips")
                gripper.move(width, self.p.step / self.cell.clock.period, self.p.force)
                steps, last_width = steps + 1, now_width
            self.feedback_message = f"holding, slip {slip:.3f}, {steps} tightening steps"
            yield
        self.feedback_message = f"held for {self.p.duration:.1f} s with {steps} tightening steps"
        return Status.SUCCESS
