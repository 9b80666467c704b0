"""Pinch: close the fingers slowly until both pads feel a squeeze, stop there and leave the width
at first firm contact on the blackboard (`/task/pinch_width`): a tactile measure of how wide the
object between the fingers is, without squeezing it harder than `squeeze`."""

from __future__ import annotations

from typing import ClassVar

from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, time_limit
from behaviours.skill_kit.hand import grip_squeeze

PINCH_WIDTH = "/task/pinch_width"


class Pinch(ProgramSkill):
    NAME = "pinch"
    SUMMARY = "close until the pads feel a squeeze, stop, and report the width at first firm contact"
    PARAMS: ClassVar[dict[str, Param]] = {
        "squeeze": Param("float", "squeeze both pads must feel to stop", 0.2, "px", min=0.01),
        "speed": Param("float", "closing speed", 0.01, "m/s", min=0.001, max=0.1),
        "force": Param("float", "gripper force limit while closing", 10.0, "N", min=1.0, max=100.0),
        "max_time": time_limit(15.0, "give up when nothing was felt within this time"),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.GRIPPER_WIDTH, keys.GRIPPER_FAULT, keys.GRIPPER_MOVING)
    WRITES = (PINCH_WIDTH,)

    def program(self):
        gripper = self.cell.gripper
        gripper.move(0.0, speed=self.p.speed, force=self.p.force)
        deadline = self.now() + self.p.max_time
        self.feedback_message = "closing"
        while True:
            yield  # the snapshot shows the motion from the next tick on
            if self.gripper_fault():
                return self.fail(f"gripper fault: {self.gripper_fault()}")
            squeeze = grip_squeeze(*self.tactile())
            if squeeze >= self.p.squeeze:
                gripper.stop()
                self.write(PINCH_WIDTH, self.gripper_width())
                self.feedback_message = f"felt {squeeze:.2f} px at {self.gripper_width() * 1000:.1f} mm"
                return Status.SUCCESS
            if not self.gripper_moving():
                return self.fail(f"the fingers stopped at {self.gripper_width() * 1000:.1f} mm feeling only "
                                 f"{squeeze:.2f} px: nothing to pinch, or raise 'force'")
            if self.now() > deadline:
                gripper.stop()
                return self.fail(f"felt only {squeeze:.2f} px after {self.p.max_time:.0f} s")
