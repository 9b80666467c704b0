"""Place the element: announce the release (/task/asbuilt with status `placing`, written to the
as-built model by `for_each_element` before the fingers move), open the gripper gently with the
leaky integrator x_t = a x_{t-1} - (1 - a) L (L = -1 while releasing), check the element stayed
standing between the fingers, record it `placed` with its as-built pose and load, and back out."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, time_limit
from behaviours.skill_kit.control import leaky_open
from behaviours.skill_kit.geometry import translated
from behaviours.skill_kit.registry import register


@register
class PlaceElement(ProgramSkill):
    NAME = "place_element"
    SUMMARY = "release with the leaky integrator, record the as-built pose, retract"
    PARAMS = {
        "alpha": Param("float", "leaky-integrator inertia (closer to 1 opens more gently)", 0.9, min=0.0, max=0.999),
        "opening": Param("float", "opening beyond the grasp width", 0.02, "m", min=0.001),
        "retract": Param("vector", "base-frame retreat after release", [0.0, -0.2, 0.0], "m", length=3),
        "lift": Param("float", "height gained after the retreat", 0.1, "m", min=0.0),
        "speed": Param("float", "retreat speed", 0.1, "m/s", min=0.001, device="arm_speed"),
        "max_time": time_limit(10.0, "give up when the fingers have not opened within this time"),
    }
    READS = (keys.ELEMENT, keys.FV_LEFT, keys.FV_RIGHT, keys.MEASURED_LOAD, keys.ELEMENT_LENGTH,
             keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING, keys.GRIPPER_WIDTH, keys.GRIPPER_FAULT)
    OPTIONAL_READS = (keys.ELEMENT_LENGTH,)  # measured by vis_scan; else the design length
    WRITES = (keys.ASBUILT,)

    def program(self):
        gripper = self.cell.gripper
        element = self.read(keys.ELEMENT)
        pose = self.pose()
        length = self.read(keys.ELEMENT_LENGTH, element["size"][0])
        asbuilt = {"element": element["id"], "load": self.read(keys.MEASURED_LOAD),
                   "pose": np.array([pose[0], pose[1], length / 2.0, 0.0, -np.pi / 2, 0.0])}  # upright
        self.write(keys.ASBUILT, {**asbuilt, "status": "placing"})
        self.feedback_message = "announcing the release"
        yield  # the intent is on disk before the fingers open
        target = min(self.gripper_width() + self.p.opening, gripper.max_width)
        self.feedback_message = "releasing"
        fault = yield from leaky_open(self, target, self.p.alpha, self.p.max_time)
        if fault:
            return self.fail(fault)
        left, right = self.tactile()
        if not (left.obj.present or right.obj.present):
            return self.fail(f"element {element['id']} not seen between the fingers after release: "
                             "it fell")
        self.write(keys.ASBUILT, {**asbuilt, "status": "placed"})
        for target_pose in (translated(pose, self.p.retract),
                            translated(pose, np.add(self.p.retract, [0.0, 0.0, self.p.lift]))):
            fault = yield from self.move(target_pose, self.p.speed)
            if fault:
                return self.fail(fault)
        self.feedback_message = f"placed {element['id']}"
        return Status.SUCCESS
