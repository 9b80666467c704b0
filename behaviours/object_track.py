"""ObjectTrack: keep the object centred in the FingerVision views by proximity vision (the
paper's rule x_{t+1} = x_t + min(x_bar, x_max) 1(|x_bar| > x_eps) per axis): the centroid
along the pads gives tool x and z, the area difference between the fingers gives tool y."""

from __future__ import annotations

import numpy as np

from behaviours.base import Param
from behaviours.follow_me import TrackingSkill
from behaviours.registry import register


@register
class ObjectTrack(TrackingSkill):
    NAME = "object_track"
    SUMMARY = "follow the object's motion in the fingers' camera views (FollowMe by vision)"
    PARAMS = {
        "gain": Param("float", "step per tick per unit of centroid offset (image fraction)", 0.02, "m", min=0.0),
        "max_offset": Param("float", "offsets are clipped to this (x_max)", 0.1, min=0.0),
        "eps": Param("float", "dead band on the offset (x_eps)", 0.02, min=0.0),
        **TrackingSkill.COMMON,
    }

    def velocity(self, left, right) -> np.ndarray:
        # Image x is mirrored on the left finger; image y runs along tool z on both.
        offset = np.array([
            0.5 * (right.obj.centroid[0] - left.obj.centroid[0]),
            right.obj.area - left.obj.area,  # nearer the right pad looks bigger there
            0.5 * (right.obj.centroid[1] + left.obj.centroid[1]),
        ])
        step = np.clip(offset, -self.p.max_offset, self.p.max_offset) * (np.abs(offset) > self.p.eps)
        return step * self.p.gain / self.cell.clock.period
