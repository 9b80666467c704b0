"""ForceTrack+SpeedCtrl: move the hand along the force a person puts on the held object,
x_{t+1} = x_t + alpha (f_t - f_min) 1(|f_t| > eps), alpha = (v_max - v_min) / (f_max - f_min),
on the marker force relative to the grasp's own (taken at the start). The closing-axis (normal)
component is weighted by the sensor's shear/normal gain ratio (`normal_scale`, from the cell's sensor
profile unless given), so a newton counts the same on every axis."""

from __future__ import annotations

import numpy as np

from behaviours.skill_kit.base import Param
from behaviours.skill_kit.control import MovingAverage, speed_ctrl, speed_ctrl_gain
from behaviours.skill_kit.follow_me import TrackingSkill
from behaviours.skill_kit.hand import hand_force
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.sensor import sensor_profile


@register
class ForceTrack(TrackingSkill):
    NAME = "force_track"
    SUMMARY = "follow a person's push or pull on the held object (FollowMe) with SpeedCtrl"
    PARAMS = {
        "v_min": Param("float", "speed at f_min", 0.0, "m/s", min=0.0, device="arm_speed"),
        "v_max": Param("float", "speed at f_max and above", 0.1, "m/s", min=0.0, max=0.25, device="arm_speed"),
        "f_min": Param("float", "force mapped to v_min", 0.05, "px", min=0.0),
        "f_max": Param("float", "force mapped to v_max", 2.0, "px", min=0.0),
        "eps": Param("float", "dead band: smaller forces do not move the arm", 0.08, "px", min=0.0),
        "normal_scale": Param("float", "weight of the closing-axis force (default: the sensor profile's "
                              "shear/normal gain ratio, so forces compare in newtons)", None, min=0.0),
        "smoothing": Param("int", "ticks in the force moving average", 3, min=1),
        "reference_ticks": Param("int", "ticks averaged for the grasp's own force f_0", 10, min=1),
        **TrackingSkill.COMMON,
    }

    @classmethod
    def validate(cls, params) -> None:
        super().validate(params)
        speed_ctrl_gain(params["v_min"], params["v_max"], params["f_min"], params["f_max"])
        if params["v_max"] < params["v_min"]:
            raise ValueError(f"v_max ({params['v_max']}) must not be below v_min ({params['v_min']})")

    def start(self):
        scale = self.p.normal_scale
        if scale is None:
            scale = sensor_profile(self.cell).shear_to_normal
        self._scale = np.array([1.0, scale, 1.0])
        self._average = MovingAverage(self.p.smoothing)
        total = np.zeros(3)
        for _ in range(self.p.reference_ticks):
            total += hand_force(*self.tactile())
            yield
        self._f0 = total / self.p.reference_ticks

    def velocity(self, left, right) -> np.ndarray:
        f = self._average.update((hand_force(left, right) - self._f0) * self._scale)
        return speed_ctrl(f, self.p.v_min, self.p.v_max, self.p.f_min, self.p.f_max, self.p.eps)
