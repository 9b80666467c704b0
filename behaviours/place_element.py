"""Place the element: open the gripper gently with the leaky integrator
x_t = a x_{t-1} - (1 - a) L (L = -1 while releasing), check the element stayed standing
between the fingers, record the as-built pose and load, and back out."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours import keys
from behaviours.base import Param, ProgramSkill
from behaviours.control import LeakyIntegrator
from behaviours.geometry import translated
from behaviours.registry import register


@register
class PlaceElement(ProgramSkill):
    NAME = "place_element"
    SUMMARY = "release with the leaky integrator, record the as-built pose, retract"
    PARAMS = {
        "alpha": Param("float", "leaky-integrator inertia (closer to 1 opens more gently)", 0.9, min=0.0, max=0.999),
        "opening": Param("float", "opening beyond the grasp width", 0.02, "m", min=0.001),
        "retract": Param("vector", "base-frame retreat after release", [0.0, -0.2, 0.0], "m", length=3),
        "lift": Param("float", "height gained after the retreat", 0.1, "m", min=0.0),
        "speed": Param("float", "retreat speed", 0.1, "m/s", min=0.001),
    }
    READS = (keys.ELEMENT, keys.FV_LEFT, keys.FV_RIGHT, keys.MEASURED_LOAD, keys.ELEMENT_LENGTH)
    WRITES = (keys.ASBUILT,)

    def program(self):
        gripper = self.cell.gripper
        element = self.read(keys.ELEMENT)
        start = gripper.width()
        target = min(start + self.p.opening, gripper.max_width)
        drive = LeakyIntegrator(self.p.alpha)
        self.feedback_message = "releasing"
        while gripper.width() < target - 1e-4:
            x = drive.step(-1.0)  # 0 -> 1 with inertia
            gripper.move(start + x * (target - start), speed=0.05)
            yield
            if gripper.fault():
                return self.fail(f"gripper fault: {gripper.fault()}")
        left, right = self.tactile()
        if not (left.obj.present or right.obj.present):
            return self.fail(f"element {element['id']} not seen between the fingers after release: "
                             "it fell")
        pose = self.cell.arm.pose()
        length = self.read(keys.ELEMENT_LENGTH, element["size"][0])
        asbuilt = np.array([pose[0], pose[1], length / 2.0, 0.0, -np.pi / 2, 0.0])  # upright
        self.write(keys.ASBUILT, {"element": element["id"], "pose": asbuilt,
                                  "load": self.read(keys.MEASURED_LOAD)})
        for target_pose in (translated(pose, self.p.retract),
                            translated(pose, np.add(self.p.retract, [0.0, 0.0, self.p.lift]))):
            fault = yield from self.move(target_pose, self.p.speed)
            if fault:
                return self.fail(fault)
        self.feedback_message = f"placed {element['id']}"
        return Status.SUCCESS
