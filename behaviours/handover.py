"""Handover+LeakyInt: take an object from a person, or give one to a person, moving the
gripper through the leaky integrator x_t = a x_{t-1} - (1 - a) L.

receive: L = 1 while the object both slips (the person moves it) and presses the markers (force
change on enough markers): the fingers close with inertia and open again if the person pulls
back; once the fingers stop on the object at the force limit it is grasped, and received when
the person has let go (nothing slips for `settle` ticks).
give: first waits until the skin has settled (a lagging skin still shows the weight and grip of
the hand-over and the carry for up to a few of its time constants; what is still to come is
measured on the spot, `skill_kit.settle`), then takes its references; once the person tugs,
L = -1 opens gently; done when the fingers are open and the object
is gone (its area under `gone_share` of the area seen while held). A tug is a change felt (force
change on enough markers, or slip) while the force the object puts on the hand has turned away
from straight down by more than `weight_angle`, or grows faster than `tug_rate`: a person pulling
the object away. Weight added slowly (sand poured into a
held box) pulls straight down and is not a tug: the skill keeps holding.
Each wait on the person is bounded by `wait`: receive gives up when nothing is offered (or the
fingers have not closed on the object) within `wait`, or the person does not let go within
`wait` of the grasp; give gives up when the object is not taken within `wait`, or slips out
while it waits.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, gone_share
from behaviours.skill_kit.control import ForceChangeDetector, LeakyIntegrator
from behaviours.skill_kit.geometry import rotation
from behaviours.skill_kit.hand import object_area, still_seen, total_slip
from behaviours.skill_kit.marker_shift import MarkerShift, hand_axes
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.settle import Settling
from perception.wrench import marker_forces

NOISE_FACTOR = 4.0  # a pull counts beyond this many times its noise (a 3-axis noise passes it ~1 tick in 1000)


@register
class Handover(ProgramSkill):
    NAME = "handover"
    SUMMARY = "receive an object from a person, or give one, through the leaky-integrator gripper"
    PARAMS = {
        "mode": Param("str", "take the object from the person, or give it to them", "receive",
                      choices=("receive", "give")),
        "alpha": Param("float", "leaky-integrator inertia (closer to 1 moves more gently)", 0.9, min=0.0, max=0.999),
        "slip": Param("float", "slip (both fingers) that counts as the object moving", 0.05, min=0.0),
        "threshold": Param("float", "per-marker force change that counts as pressed", 0.3, "px", min=0.0),
        "min_markers": Param("int", "markers that must change for the force to count", 8, min=1),
        "force": Param("float", "gripper force limit", 20.0, "N", min=0.0, device="gripper_force"),
        "opening": Param("float", "give: how far to open beyond the holding width", 0.02, "m", min=0.001),
        "settle": Param("int", "receive: ticks without slip on the stopped gripper that mean it is ours", 10, min=1),
        "wait": Param("float", "give up when the person has not acted within this time", 15.0, "s", min=0.0),
        "weight_angle": Param("float", "give: a force change within this angle of straight down is added "
                              "weight, not a tug", 45.0, "deg", min=0.0, max=90.0),
        "tug_rate": Param("float", "give: a force change growing faster than this is a tug whatever its "
                          "direction", 3.0, "px/s", min=0.0),
        "gone_share": gone_share(),
        "min_pull": Param("float", "give: least change of the hand force that counts as a pull (raised to 4 times "
                          "the pull's noise measured while the skin settles)", 0.1, "px", min=0.0),
        "settle_window": Param("float", "give: window over which the skin's settling is measured before the "
                               "references are taken (its three stretches' means must show what is still to come)",
                               1.0, "s", min=0.2),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.GRIPPER_WIDTH, keys.GRIPPER_OBJECT, keys.ROBOT_POSE)
    NEEDS = ("giver",)
    RATE_TICKS = 3  # the growth of the pull is measured over this many ticks

    def _pressed(self, detector: ForceChangeDetector) -> bool:
        left, right = self.tactile()
        return detector.update(marker_forces(left.markers, "left"), marker_forces(right.markers, "right"))

    def program(self):
        detector = ForceChangeDetector(self.p.threshold, self.p.min_markers)
        drive = LeakyIntegrator(self.p.alpha)
        start = self.now()
        steps = self.receive if self.p.mode == "receive" else self.give
        return (yield from steps(detector, drive, start))

    def receive(self, detector: ForceChangeDetector, drive: LeakyIntegrator, start: float):
        gripper = self.cell.gripper
        open_width, grasped_at, still = self.gripper_width(), None, 0
        while still < self.p.settle:
            pressed = self._pressed(detector)
            slipping = total_slip(*self.tactile()) > self.p.slip
            if grasped_at is None and self.gripper_object():
                grasped_at = self.now()
            if grasped_at is not None:  # the fingers stopped on it at the force limit: wait for the person to let go
                if object_area(*self.tactile()) <= 0.0:
                    return self.fail("the object slipped out after the grasp: raise 'force'")
                if self.now() - grasped_at > self.p.wait:
                    return self.fail(f"grasped, but the person did not let go within {self.p.wait:.0f} s")
                still = 0 if slipping else still + 1
                self.feedback_message = f"grasped at {self.gripper_width() * 1000:.1f} mm, waiting for the person to let go"
            else:
                closing = -drive.step(1.0 if pressed and slipping else 0.0)  # 0 open .. 1 closed
                gripper.move(open_width * (1.0 - closing), speed=gripper.max_speed, force=self.p.force)
                if self.now() - start > self.p.wait:
                    if closing < 0.01:
                        return self.fail(f"no object offered within {self.p.wait:.0f} s (nothing pressed "
                                         "and moved between the fingers)")
                    gripper.stop()
                    return self.fail(f"the fingers did not close on the object within {self.p.wait:.0f} s "
                                     f"({closing * 100:.0f} % closed): is it too narrow for 'force'?")
                self.feedback_message = (f"{'closing' if pressed and slipping else 'waiting'}: "
                                         f"{closing * 100:.0f} % closed, {detector.changed} markers pressed")
            yield
        self.feedback_message = f"received, holding at {self.gripper_width() * 1000:.1f} mm"
        return Status.SUCCESS

    def give(self, detector: ForceChangeDetector, drive: LeakyIntegrator, start: float):
        gripper = self.cell.gripper
        held_area = object_area(*self.tactile())
        if held_area <= 0.0:
            return self.fail("nothing in the gripper to give")
        problem = yield from self._wait_for_tug(held_area, start)
        if problem:
            return self.fail(problem)
        hold_width = self.gripper_width()
        target = min(hold_width + self.p.opening, gripper.max_width)
        while (self.gripper_width() < target - 1e-4
               or still_seen(object_area(*self.tactile()), held_area, self.p.gone_share)):
            opened = drive.step(-1.0)  # 0 -> 1 with inertia
            gripper.move(hold_width + opened * (target - hold_width), speed=gripper.max_speed)
            if self.now() - start > self.p.wait:
                return self.fail(f"opened, but the object was not taken within {self.p.wait:.0f} s")
            self.feedback_message = f"releasing, {opened * 100:.0f} % open"
            yield
        self.feedback_message = "given"
        return Status.SUCCESS

    def _pull(self, shift: MarkerShift) -> np.ndarray:
        """The change of the hand force since `shift`'s reference, in base axes (px)."""
        return rotation(self.pose()) @ hand_axes(shift.change(*self.tactile()))

    def _wait_for_tug(self, held_area: float, start: float):
        """Steps until the person tugs (None) or why the wait ended otherwise. First the skin
        settles: a lagging skin still shows the weight and grip of the hand-over and the carry, and
        that rest of its answer, felt after the reference, is a pull in a direction the weight rule
        cannot judge (seen: 0.15 px at 45 deg from straight down with a 0.9 s skin). So the
        references are taken once what is still to come (`Settling`, measured on the spot) is under
        half of `min_pull`, and the least pull is raised to 4 times the pull's noise measured
        meanwhile. A lift (upward pull) while the skin settles is a tug at once."""
        period = self.cell.clock.period
        shift = MarkerShift()  # the pull read marker by marker: a firm grip's lost markers do not move it
        shift.add_reference(*self.tactile())
        settling = Settling(max(6, round(self.p.settle_window / period)), 0.5 * self.p.min_pull, period)
        settled = False
        recent: deque[float] = deque(maxlen=self.RATE_TICKS + 1)
        while not settled:
            if not still_seen(object_area(*self.tactile()), held_area, self.p.gone_share):
                return "the object slipped out while waiting for the person: grasp it firmer, or hold it with 'hold'"
            pull = self._pull(shift)
            settled = settling.update(pull)
            recent.append(float(np.linalg.norm(pull)))
            least = self._least_pull(settling)
            # A settling skin shows weight (down), never a lift, and it drifts slowly: a lift, or a
            # pull growing faster than `tug_rate`, is a tug even now, once 6 ticks have measured
            # the pull's noise (a jittery skin's pull jumps by more than `min_pull` from tick to tick).
            if settling.noise is not None and (pull[2] > least or (recent[-1] > least
                                                                   and self._rate(recent) > self.p.tug_rate)):
                return None
            if self.now() - start > self.p.wait:
                return f"no one took the object within {self.p.wait:.0f} s; still holding it (the skin never settled)"
            self.feedback_message = "waiting for the skin to settle before feeling for a tug"
            yield
        least = self._least_pull(settling)
        shift = MarkerShift()
        shift.add_reference(*self.tactile())
        detector = ForceChangeDetector(self.p.threshold, self.p.min_markers)
        recent.clear()
        while True:
            if not still_seen(object_area(*self.tactile()), held_area, self.p.gone_share):
                return "the object slipped out while waiting for the person: grasp it firmer, or hold it with 'hold'"
            felt = self._pressed(detector) or total_slip(*self.tactile()) > self.p.slip
            pull = self._pull(shift)
            recent.append(float(np.linalg.norm(pull)))
            kind = self._kind_of(pull, recent, least)
            if felt and kind == "tug":
                return None
            if self.now() - start > self.p.wait:
                return f"no one took the object within {self.p.wait:.0f} s; still holding it"
            self.feedback_message = (f"waiting for the person to take it ({detector.changed} markers changed"
                                     f"{', weight added, not a tug' if felt and kind == 'weight' else ''})")
            yield

    def _least_pull(self, settling: Settling) -> float:
        """`min_pull`, or 4 times the pull's noise measured while settling when that is more."""
        return max(self.p.min_pull, NOISE_FACTOR * (settling.noise or 0.0))

    def _kind_of(self, pull: np.ndarray, recent: deque, least: float) -> str | None:
        """'tug', 'weight', or None (no pull yet: under `least`) for the change `pull` of the hand
        force since the reference, `recent` holding its last magnitudes (one per tick)."""
        size = float(np.linalg.norm(pull))
        if size < least:
            return None
        downward = -pull[2] / size >= math.cos(math.radians(self.p.weight_angle))
        return "weight" if downward and self._rate(recent) <= self.p.tug_rate else "tug"

    def _rate(self, recent: deque) -> float:
        """How fast the pull's magnitude grew over `recent` (one per tick), px/s."""
        return (recent[-1] - recent[0]) / (self.cell.clock.period * (len(recent) - 1)) if len(recent) > 1 else 0.0
