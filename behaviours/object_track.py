"""ObjectTrack: keep the object centred in the FingerVision views by proximity vision (the
paper's rules). Along the pads (tool x and z) the centroid offset moves the hand:
x_{t+1} = x_t + min(x_bar, x_max) 1(|x_bar| > x_eps). Along the closing axis (tool y) the view
cannot show a shift, only how hard the object presses into a pad, which grows the area that pad
sees: with M_t the area the left pad sees, y_{t+1} = y_t + Delta (1(M_t <= M_eps) - 1(M_t > M_eps)),
so the hand follows the object off the left pad (+y) or into it (-y). A dead band `area_band`
about M_eps keeps the hand still while the object rests."""

from __future__ import annotations

import numpy as np

from behaviours.skill_kit.base import Param
from behaviours.skill_kit.follow_me import TrackingSkill
from behaviours.skill_kit.registry import register


@register
class ObjectTrack(TrackingSkill):
    NAME = "object_track"
    SUMMARY = "follow the object's motion in the fingers' camera views (FollowMe by vision)"
    PARAMS = {
        "gain": Param("float", "step per tick per unit of centroid offset (image fraction)", 0.02, "m", min=0.0),
        "max_offset": Param("float", "offsets are clipped to this (x_max)", 0.1, min=0.0),
        "eps": Param("float", "dead band on the offset (x_eps)", 0.02, min=0.0),
        "delta": Param("float", "closing-axis step per tick (Delta)", 0.0015, "m", min=0.0, max=0.005),
        "m_eps": Param("float", "closing-axis area threshold M_eps (share of the left pad's image); 0 takes "
                       "the area it sees at the start", 0.0, min=0.0, max=1.0),
        "area_band": Param("float", "dead band about M_eps, share of M_eps", 0.05, min=0.0, max=1.0),
        **TrackingSkill.COMMON,
    }

    def start(self):
        left, _ = self.tactile()
        self._m_eps = self.p.m_eps or left.obj.area
        return
        yield

    def velocity(self, left, right) -> np.ndarray:
        # Image x is mirrored on the left finger; image y runs along tool z on both.
        offset = np.array([0.5 * (right.obj.centroid[0] - left.obj.centroid[0]),
                           0.5 * (right.obj.centroid[1] + left.obj.centroid[1])])
        along = np.clip(offset, -self.p.max_offset, self.p.max_offset) * (np.abs(offset) > self.p.eps) * self.p.gain
        m = left.obj.area
        off_left = float(m <= self._m_eps) - float(m > self._m_eps)
        across = self.p.delta * off_left * (abs(m - self._m_eps) > self.p.area_band * self._m_eps)
        return np.array([along[0], across, along[1]]) / self.cell.clock.period
