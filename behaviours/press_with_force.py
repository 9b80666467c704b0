"""PressWithForce (ForceLearn): press the held object along the tool z axis until the force a
learned model predicts from the marker field reaches a target in newtons, and hold there.

The speed is proportional to the remaining force error (capped), so the press slows as it
approaches the target; it succeeds once the prediction stays within the tolerance."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, time_limit
from behaviours.skill_kit.control import MovingAverage
from behaviours.skill_kit.geometry import rotation
from behaviours.skill_kit.model_files import UsesModel
from behaviours.skill_kit.registry import register
from perception.learning.features import tick_features


@register
class PressWithForce(UsesModel, ProgramSkill):
    NAME = "press_with_force"
    MODEL_KIND = "force"
    SUMMARY = "press along tool z until the learned force (ForceLearn) reaches a target in newtons"
    PARAMS = {
        "model": Param("str", "ForceLearn model file (fvtree train force)", "trees/models/force_sim.npz"),
        "target": Param("float", "force to press with", 5.0, "N", min=0.0),
        "tolerance": Param("float", "how close to the target counts as reached", 0.3, "N", min=0.01),
        "gain": Param("float", "press speed per newton of force error", 0.002, "m/s/N", min=0.0),
        "max_speed": Param("float", "press speed limit", 0.005, "m/s", min=1e-4, max=0.05, device="arm_speed"),
        "settle": Param("int", "ticks the force must stay within the tolerance", 10, min=1),
        "max_travel": Param("float", "give up after pressing this far", 0.1, "m", min=0.0, max=1.0),
        "max_force": Param("float", "abort above this force", 20.0, "N", min=0.0),
        "smoothing": Param("int", "ticks in the moving average of the predicted force", 3, min=1),
        "max_time": time_limit(30.0, "give up when the force has not settled within this time"),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT)
    WRITES = (keys.PRESS_FORCE,)

    def program(self):
        from perception.learning.force import predict_force  # scikit-learn: loaded by a run, not by `fvtree validate`

        if self.model is None:
            return self.fail(self.model_error)
        model = self.model
        arm = self.cell.arm
        start, t0, steady, average = self.pose(), self.now(), 0, MovingAverage(self.p.smoothing)
        while steady < self.p.settle:
            force = float(average.update(predict_force(model, tick_features(*self.tactile()))))
            error = self.p.target - force
            pose = self.pose()
            travelled = float(np.linalg.norm(pose[:3] - start[:3]))
            if force > self.p.max_force:
                arm.stop()
                return self.fail(f"pressing with {force:.1f} N, above max_force {self.p.max_force} N: "
                                 "lower the gain or the speed")
            if travelled > self.p.max_travel:
                arm.stop()
                return self.fail(f"pressed {travelled * 1000:.0f} mm and feel only {force:.2f} N: "
                                 "nothing under the object, or the model does not fit this object")
            held = self.held_at_box()
            if held:
                arm.stop()
                return self.fail(f"pressed {travelled * 1000:.0f} mm to the workspace box's {held} and feel "
                                 f"only {force:.2f} N: the safety layer stops the arm there")
            if self.now() - t0 > self.p.max_time:
                arm.stop()
                return self.fail(f"the force did not settle within {self.p.tolerance} N of the target in "
                                 f"{self.p.max_time:.0f} s (now {force:.2f} N): lower the gain, or "
                                 "raise 'smoothing' against a noisy prediction")
            fault = self.arm_fault()
            if fault:
                return self.fail(f"arm fault: {fault}")
            steady = steady + 1 if abs(error) <= self.p.tolerance else 0
            speed = float(np.clip(self.p.gain * error, -self.p.max_speed, self.p.max_speed))
            arm.speed_linear(np.r_[rotation(pose)[:, 2] * speed, 0.0, 0.0, 0.0])
            self.feedback_message = f"pressing with {force:.2f} N of {self.p.target:.2f} N"
            yield
        arm.stop()
        self.write(keys.PRESS_FORCE, force)
        self.feedback_message = f"pressing with {force:.2f} N (target {self.p.target:.2f} N)"
        return Status.SUCCESS
