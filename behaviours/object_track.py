"""ObjectTrack: keep the object centred in the FingerVision views by proximity vision (the
paper's rules). Along the pads (tool x and z) the centroid offset moves the hand:
x_{t+1} = x_t + min(x_bar, x_max) 1(|x_bar| > x_eps). Along the closing axis (tool y) the view
cannot show a shift, only how hard the object presses into a pad, which grows the area that pad
sees: with M_t the area the left pad sees, y_{t+1} = y_t + Delta (1(M_t <= M_eps) - 1(M_t > M_eps)),
so the hand follows the object off the left pad (+y) or into it (-y). A dead band `area_band`
about M_eps keeps the hand still while the object rests.

That area changes only as much as the gel under the object compresses (the object comes nearer the
camera by load / gel stiffness, a few per cent of the camera's depth at most), so vision sees a
push along the closing axis weakly or not at all (a stiff gel, a camera set deep, an object filling
the view): on the randomised cell's stiffer gels the area flickers in and out of its dead band and
the hand falls behind by a hair over the scene's 25 mm rms. The pads' normal loads, read from the
markers, do show the push (the paper: force tracking should be preferred on that axis). With
`closing_force` (the default) a tick whose area stays inside its dead band steps Delta along the
push the pads show, when it is beyond `push_noise` times the push's noise measured over the
reference ticks (and at least `min_push`): vision where it sees, the markers where it does not.
With `closing_force: false` (vision alone, the paper's experiment) a push beyond `unseen_force` held
for `unseen_time` while the area stays inside its dead band ends the skill with FAILURE saying
vision cannot follow the axis perpendicular to the skin, instead of succeeding with the hand left
behind; force_track follows that axis. It fails, too, when the pipeline warns that its object
colour model matches more of the empty view than `max_false_object` of the object's own seen area
(a background of the object's colour, glare): the centroid and area it would follow are then not
the object's."""

from __future__ import annotations

import numpy as np

from behaviours.skill_kit.base import Param
from behaviours.skill_kit.follow_me import TrackingSkill
from behaviours.skill_kit.hand import false_object, hand_force
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.sensor import sensor_profile
from behaviours.skill_kit.settle import reading_noise


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
                       "the mean area it sees over the first `reference_ticks`", 0.0, min=0.0, max=1.0),
        "reference_ticks": Param("int", "ticks averaged at the start for M_eps and the pads' own normal loads",
                                 10, min=1),
        "area_band": Param("float", "dead band about M_eps, share of M_eps", 0.05, min=0.0, max=1.0),
        "closing_force": Param("bool", "closing axis: where the area stays in its dead band, follow the push the "
                               "pads' normal loads show (false: vision alone, and an unseen push fails)", True),
        "push_noise": Param("float", "closing_force: a push counts beyond this many times its noise measured over "
                            "the reference ticks", 6.0, min=0.0),
        "min_push": Param("float", "closing_force: and beyond this at least", 2.0, "N", min=0.0),
        "unseen_force": Param("float", "closing_force false: closing-axis push (difference of the pads' normal loads "
                              "from the grasp's, from the markers) that vision must see; 0 never checks", 8.0, "N",
                              min=0.0),
        "max_false_object": Param("float", "fail when a camera's colour model takes more than this share of the "
                                  "object's own seen area of the empty view for the object (pipeline's warning)", 0.5,
                                  min=0.0),
        "unseen_time": Param("float", "how long such a push may go unseen before the skill fails", 0.5, "s",
                             min=0.0),
        **TrackingSkill.COMMON,
    }

    def start(self):
        areas, pushes = np.zeros(2), []
        for tick in range(self.p.reference_ticks):
            if tick:
                yield
            left, right = self.tactile()
            areas += (left.obj.area, right.obj.area)
            pushes.append(hand_force(left, right)[1])
        areas /= self.p.reference_ticks
        self._area0 = {"left": areas[0], "right": areas[1]}
        self._m_eps = self.p.m_eps or areas[0]
        self._f0 = float(np.mean(pushes))
        self._px_per_n = sensor_profile(self.cell).normal_px_per_n
        noise = reading_noise(pushes) / self._px_per_n if len(pushes) >= 3 else 0.0  # N
        self._least_push = max(self.p.min_push, self.p.push_noise * noise)
        self._unseen_since: float | None = None

    def _push(self, left, right) -> float:
        """The closing-axis push (N, + along tool y): the pads' normal loads' difference from the grasp's."""
        return (hand_force(left, right)[1] - self._f0) / self._px_per_n

    def _area_steps(self, area: float) -> bool:
        """Whether the left pad's area is outside the dead band about M_eps (the closing-axis rule acts)."""
        return abs(area - self._m_eps) > self.p.area_band * self._m_eps

    def blind(self, left, right) -> str:
        blind = false_object((left, right), self._area0, self.p.max_false_object)
        if blind:
            return blind
        push = self._push(left, right)
        limit = self.p.unseen_force
        if (self.p.closing_force or "y" not in self.p.axes or not limit or abs(push) <= limit
                or self._area_steps(left.obj.area)):
            self._unseen_since = None
            return ""
        if self._unseen_since is None:
            self._unseen_since = self.now()
        if self.now() - self._unseen_since < self.p.unseen_time:
            return ""
        return (f"the object is pushed along the closing axis ({push:+.1f} N on the pads for "
                f"{self.now() - self._unseen_since:.1f} s) but the area the camera sees stays within "
                f"{self.p.area_band:.0%} of M_eps: vision cannot follow the axis perpendicular to the skin; "
                "follow it with force_track")

    def velocity(self, left, right) -> np.ndarray:
        # Image x is mirrored on the left finger; image y runs along tool z on both.
        offset = np.array([0.5 * (right.obj.centroid[0] - left.obj.centroid[0]),
                           0.5 * (right.obj.centroid[1] + left.obj.centroid[1])])
        along = np.clip(offset, -self.p.max_offset, self.p.max_offset) * (np.abs(offset) > self.p.eps) * self.p.gain
        m = left.obj.area
        if self._area_steps(m):
            across = self.p.delta * (float(m <= self._m_eps) - float(m > self._m_eps))
        elif self.p.closing_force and "y" in self.p.axes:
            push = self._push(left, right)
            across = self.p.delta * np.sign(push) * (abs(push) > self._least_push)
        else:
            across = 0.0
        return np.array([along[0], across, along[1]]) / self.cell.clock.period
