"""ArmRot: turn the wrist about the fingers' closing axis in the sense of the torque the held
object puts on the fingers (estimated from the marker field), until that torque vanishes:
an asymmetric object then hangs with its centre of mass below the grasp. Once the torque has stayed
below `eps` for `settle` ticks the wrist stands still until the reading is steady (two runs of
`settle` ticks agree within eps / 2), and turns on if torque shows up meanwhile: a viscoelastic skin
shows a load up to a second late, and a wrist that stopped at the first quiet reading would leave
the object up to 10 deg from hanging."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, time_limit
from behaviours.skill_kit.geometry import angle_between, rotation
from behaviours.skill_kit.hand import hand_torque, object_area
from behaviours.skill_kit.registry import register


@register
class ArmRot(ProgramSkill):
    NAME = "arm_rot"
    SUMMARY = "rotate the arm until the in-finger torque of the held object goes to zero"
    PARAMS = {
        "gain": Param("float", "wrist speed per unit of torque", 2.0, "rad/s/px", min=0.0),
        "max_speed": Param("float", "wrist speed limit (the cell refuses turns over its max_angular_speed)", 0.6, "rad/s", min=0.01, max=1.0, device="arm_angular_speed"),
        "eps": Param("float", "torque that counts as zero", 0.02, "px", min=0.0),
        "settle": Param("int", "ticks the torque must stay below eps", 5, min=1),
        "max_angle": Param("float", "give up after turning this far", 180.0, "deg", min=1.0, max=360.0),
        "max_time": time_limit(30.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT)
    NEEDS = ("pivot",)
    WRITES = (keys.ARM_ROTATION,)

    def program(self):
        arm = self.cell.arm
        start, t0 = self.pose(), self.now()
        if object_area(*self.tactile()) <= 0.0:
            return self.fail("nothing held between the fingers to balance")
        quiet = 0
        still: deque[float] = deque(maxlen=2 * self.p.settle)  # readings while standing still
        while True:
            torque = hand_torque(*self.tactile())
            pose = self.pose()
            turned = math.degrees(angle_between(start, pose))
            if turned > self.p.max_angle:
                arm.stop()
                return self.fail(f"turned {turned:.0f} deg and the torque is still {torque:.2f} px: "
                                 "is the object caught on something?")
            if self.now() - t0 > self.p.max_time:
                arm.stop()
                return self.fail(f"the torque did not settle below {self.p.eps} px within "
                                 f"{self.p.max_time:.0f} s (now {torque:.2f} px, turned {turned:.0f} deg): "
                                 "lower the gain if the wrist swings back and forth")
            fault = self.arm_fault()
            if fault:
                return self.fail(f"arm fault: {fault}")
            if quiet >= self.p.settle:  # standing: the skin may not show the whole torque yet
                still.append(torque)
                if abs(torque) >= self.p.eps:
                    quiet = 0  # more torque showed up: turn on
                elif len(still) == still.maxlen and steady(still, self.p.eps):
                    break
            else:
                quiet = quiet + 1 if abs(torque) < self.p.eps else 0
                rate = float(np.clip(self.p.gain * torque, -self.p.max_speed, self.p.max_speed))
                arm.speed_linear(np.r_[0.0, 0.0, 0.0, rotation(pose)[:, 1] * rate])
                if quiet >= self.p.settle:
                    arm.stop()
                    still.clear()
            self.feedback_message = f"torque {torque:.2f} px, turned {turned:.1f} deg"
            yield
        arm.stop()
        turned = math.degrees(angle_between(start, self.pose()))
        self.write(keys.ARM_ROTATION, turned)
        self.feedback_message = f"torque vanished after turning {turned:.1f} deg"
        return Status.SUCCESS


def steady(readings: deque, eps: float) -> bool:
    """Whether the mean of the newer half of `readings` is within eps / 2 of the older half's: the
    skin has shown what it will (a lagging skin keeps moving towards the load for up to a second)."""
    values = list(readings)
    half = len(values) // 2
    return abs(float(np.mean(values[half:])) - float(np.mean(values[:half]))) < eps / 8.0
