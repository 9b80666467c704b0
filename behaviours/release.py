"""Release: let go of whatever the fingers hold, opening gently with the leaky integrator
x_t = a x_{t-1} - (1 - a) L (L = -1), then judge the release by feel and sight: the squeeze the
pads feel must have dropped (below `stuck_share` of the squeeze before, and `max_squeeze`, which
sits above what an empty sensor reads), else the object is stuck in the fingers; and the object must be
where `expect` says: still between the open fingers where it rests on a support ("stays"), or
gone from them ("leaves", handed over or dropped on purpose; gone: its area under `gone_share` of
the area seen while held). An object expected to stay that leaves the view fell."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, gone_share, time_limit
from behaviours.skill_kit.control import leaky_open
from behaviours.skill_kit.hand import grip_squeeze, object_area, still_seen
from behaviours.skill_kit.registry import register


@register
class Release(ProgramSkill):
    NAME = "release"
    SUMMARY = "open gently with the leaky integrator and check the object was let go as expected"
    PARAMS = {
        "alpha": Param("float", "leaky-integrator inertia (closer to 1 opens more gently)", 0.9, min=0.0, max=0.999),
        "opening": Param("float", "opening beyond the holding width", 0.02, "m", min=0.001),
        "expect": Param("str", "where the object should be once let go", "stays", choices=("stays", "leaves")),
        "max_squeeze": Param("float", "squeeze still felt after opening at or below which the object is free, "
                             "whatever it was before", 0.1, "px", min=0.0),
        "stuck_share": Param("float", "share of the squeeze felt before opening that, still felt after, means "
                             "the object is stuck", 0.5, min=0.0, max=1.0),
        "gone_share": gone_share(),
        "settle": Param("int", "ticks to wait after opening before judging", 5, min=0),
        "max_time": time_limit(10.0, "give up when the fingers have not opened within this time"),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.GRIPPER_WIDTH, keys.GRIPPER_FAULT)

    def program(self):
        before, held_area = grip_squeeze(*self.tactile()), object_area(*self.tactile())
        if held_area <= 0.0 and before <= self.p.max_squeeze:
            return self.fail("nothing between the fingers to release")
        target = min(self.gripper_width() + self.p.opening, self.cell.gripper.max_width)
        self.feedback_message = "releasing"
        fault = yield from leaky_open(self, target, self.p.alpha, self.p.max_time)
        if fault:
            return self.fail(fault)
        for _ in range(self.p.settle):
            yield
        left, right = self.tactile()
        squeeze = grip_squeeze(left, right)
        seen = still_seen(object_area(left, right), held_area, self.p.gone_share)
        if squeeze > max(self.p.max_squeeze, self.p.stuck_share * before):
            return self.fail(f"opened to {self.gripper_width() * 1000:.1f} mm but the pads still feel a squeeze "
                             f"({squeeze:.2f} of {before:.2f} px): the object is stuck between the fingers")
        if self.p.expect == "stays" and not seen:
            return self.fail("the object fell when released: it left the fingers instead of resting on its support")
        if self.p.expect == "leaves" and seen:
            return self.fail("released, but the object is still between the fingers")
        self.feedback_message = f"released at {self.gripper_width() * 1000:.1f} mm, object {self.p.expect}"
        return Status.SUCCESS
