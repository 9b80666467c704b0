"""GentleGrasp: close the gripper in small steps until the marker field changes on enough
markers (the object is touched), then squeeze a set margin so the grip carries the task loads.
A marker counts as changed beyond `threshold`, or beyond `noise_factor` times the rest noise the
first frames show when the skin (or that marker) is noisier than that (`ForceChangeDetector`)."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, time_limit
from behaviours.skill_kit.control import ForceChangeDetector
from behaviours.skill_kit.registry import register
from perception.wrench import marker_forces

# Frames the marker field is taken at rest as the fingers start closing (a third of a second at 30 Hz,
# 5 mm of closing at the default step): enough to see each marker's own noise, which a filtered
# pixel pipeline's wander and a few noisy markers make larger than three frames show.
REFERENCE_FRAMES = 10


@register
class GentleGrasp(ProgramSkill):
    NAME = "gentle_grasp"
    SUMMARY = "close step by step until FingerVision feels contact, then add a holding squeeze"
    PARAMS = {
        "step": Param("float", "gripper closing step per tick", 0.0005, "m", min=1e-5, max=0.01),
        "threshold": Param("float", "per-marker force change that counts as touched", 0.3, "px", min=0.0),
        "min_markers": Param("int", "markers that must change for contact", 10, min=1),
        "noise_factor": Param("float", "a marker counts only beyond this many times the rest noise measured "
                              "before closing (when that is above `threshold`)", 4.0, min=0.0),
        "squeeze": Param("float", "extra closing after contact, for a firm hold", 0.005, "m", min=0.0, max=0.02),
        "force": Param("float", "gripper force limit", 40.0, "N", min=0.0, device="gripper_force"),
        "min_width": Param("float", "width at which closing gives up (nothing grasped)", 0.002, "m", min=0.0, device="gripper_width"),
        "max_time": time_limit(20.0, "give up when no contact is felt within this time"),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.GRIPPER_WIDTH, keys.GRIPPER_FAULT, keys.GRIPPER_MOVING)
    WRITES = (keys.GRASP_WIDTH,)

    def program(self):
        gripper = self.cell.gripper
        detector = ForceChangeDetector(self.p.threshold, self.p.min_markers, REFERENCE_FRAMES, self.p.noise_factor)
        speed, start = self.p.step / self.cell.clock.period, self.now()
        while True:
            left, right = self.tactile()
            if detector.update(marker_forces(left.markers, "left"), marker_forces(right.markers, "right")):
                break
            width = self.gripper_width()
            if width <= self.p.min_width:
                return self.fail(f"closed to {width * 1000:.1f} mm without feeling an object")
            fault = self.gripper_fault()
            if fault:
                return self.fail(f"gripper fault: {fault}")
            if self.now() - start > self.p.max_time:
                gripper.stop()
                return self.fail(f"no contact felt within {self.p.max_time:.0f} s; the fingers stand at "
                                 f"{width * 1000:.1f} mm: are they blocked, or is FingerVision blind?")
            gripper.move(width - self.p.step, speed, self.p.force)
            self.feedback_message = f"closing, {detector.changed} markers moved over {detector.limit:.2f} px"
            yield
        contact = self.gripper_width()
        fault = yield from self.grip(contact - self.p.squeeze, speed, self.p.force)
        if fault:
            return self.fail(fault)
        self.write(keys.GRASP_WIDTH, contact)
        self.feedback_message = f"contact at {contact * 1000:.1f} mm"
        return Status.SUCCESS
