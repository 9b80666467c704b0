"""Locate the element at its pick area: go above the design pick pose with the gripper open,
lower the fingertips around it, and centre between the fingers with proximity vision (the
fingertip nearer the element sees it bigger)."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill
from behaviours.skill_kit.geometry import rotation, top_down_grasp, translated, warm_up
from behaviours.skill_kit.registry import register


@register
class LocateElement(ProgramSkill):
    NAME = "locate_element"
    SUMMARY = "find the current element at its pick pose and centre the open fingers on it"
    PARAMS = {
        "hover": Param("float", "approach height above the element's top", 0.08, "m", min=0.0, max=0.5),
        "speed": Param("float", "approach speed", 0.15, "m/s", min=0.001, max=1.0, device="arm_speed"),
        "gain": Param("float", "centring step per unit of left/right area imbalance", 0.01, "m", min=0.0),
        "tolerance": Param("float", "accepted left/right area imbalance (share of their sum)", 0.05, min=0.0, max=1.0),
        "max_ticks": Param("int", "ticks allowed for centring", 200, min=1),
    }
    READS = (keys.ELEMENT, keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING,
             keys.GRIPPER_FAULT, keys.GRIPPER_MOVING)
    NEEDS = ("elements",)
    WRITES = (keys.ELEMENT_POSE,)

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        warm_up()  # scipy's rotations loaded before the run, not on the tick that first turns the pick pose

    def program(self):
        element = self.read(keys.ELEMENT)
        if element is None:
            return self.fail(f"no element to locate: {keys.ELEMENT} is unset (use for_each_element)")
        gripper = self.cell.gripper
        gripper.move(gripper.max_width, speed=0.1)
        pick = top_down_grasp(element["pick_pose"])
        depth = element["size"][2]
        self.feedback_message = f"approaching {element['id']}"
        for target in (translated(pick, [0, 0, depth / 2 + self.p.hover]), pick):
            fault = yield from self.move(target, self.p.speed)
            if fault:
                return self.fail(fault)
        while self.gripper_moving():  # opened while the arm moved: normally done by now
            fault = self.gripper_fault()
            if fault:
                return self.fail(f"gripper fault: {fault}")
            yield
        arm = self.cell.arm
        across = rotation(self.pose())[:, 1]  # the fingers close along tool y
        for _ in range(self.p.max_ticks):
            left, right = self.tactile()
            pose = self.pose()
            if not (left.obj.present and right.obj.present):
                arm.stop()
                return self.fail(f"element {element['id']} not seen between the fingers at "
                                 f"{np.round(pose[:3], 3).tolist()}")
            total = left.obj.area + right.obj.area
            imbalance = (right.obj.area - left.obj.area) / total
            if abs(imbalance) <= self.p.tolerance:
                arm.stop()
                self.write(keys.ELEMENT_POSE, pose)
                self.feedback_message = f"centred on {element['id']}"
                return Status.SUCCESS
            # A speed command of one gain step per tick (a move per tick would start from rest
            # every tick on a real controller), capped at the approach speed.
            speed = min(self.p.gain * abs(imbalance) / self.cell.clock.period, self.p.speed)
            arm.speed_linear(np.r_[across * np.sign(imbalance) * speed, 0.0, 0.0, 0.0])
            yield
        arm.stop()
        return self.fail(f"could not centre on {element['id']} within {self.p.max_ticks} ticks")
