"""GentleGrasp: close the gripper in small steps until the marker field changes on enough
markers (the object is touched), then squeeze a set margin so the grip carries the task loads."""

from __future__ import annotations

from py_trees.common import Status

from behaviours import keys
from behaviours.base import Param, ProgramSkill
from behaviours.control import ForceChangeDetector
from behaviours.registry import register
from perception.wrench import marker_forces


@register
class GentleGrasp(ProgramSkill):
    NAME = "gentle_grasp"
    SUMMARY = "close step by step until FingerVision feels contact, then add a holding squeeze"
    PARAMS = {
        "step": Param("float", "gripper closing step per tick", 0.0005, "m", min=1e-5, max=0.01),
        "threshold": Param("float", "per-marker force change that counts as touched", 0.3, "px", min=0.0),
        "min_markers": Param("int", "markers that must change for contact", 10, min=1),
        "squeeze": Param("float", "extra closing after contact, for a firm hold", 0.005, "m", min=0.0, max=0.02),
        "force": Param("float", "gripper force limit", 40.0, "N", min=0.0),
        "min_width": Param("float", "width at which closing gives up (nothing grasped)", 0.002, "m", min=0.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT)
    WRITES = (keys.GRASP_WIDTH,)

    def program(self):
        gripper = self.cell.gripper
        detector = ForceChangeDetector(self.p.threshold, self.p.min_markers)
        speed = self.p.step / self.cell.clock.period
        while True:
            left, right = self.tactile()
            if detector.update(marker_forces(left.markers, "left"), marker_forces(right.markers, "right")):
                break
            width = gripper.width()
            if width <= self.p.min_width:
                return self.fail(f"closed to {width * 1000:.1f} mm without feeling an object")
            if gripper.fault():
                return self.fail(f"gripper fault: {gripper.fault()}")
            gripper.move(width - self.p.step, speed, self.p.force)
            self.feedback_message = f"closing, {detector.changed} markers changed"
            yield
        contact = gripper.width()
        gripper.move(contact - self.p.squeeze, speed, self.p.force)
        while gripper.is_moving():
            yield
        self.write(keys.GRASP_WIDTH, contact)
        self.feedback_message = f"contact at {contact * 1000:.1f} mm"
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        super().terminate(new_status)
        if new_status == Status.INVALID and self.cell is not None:
            self.cell.gripper.stop()
