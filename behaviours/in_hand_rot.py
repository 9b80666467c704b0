"""InHandRot: let a held object turn under its own weight by opening the gripper slowly through
the leaky integrator x_t = a x_{t-1} - (1 - a) L, and close again at the target angle.

variant torque: L = 1 (open) while the object still twists the fingers (|torque| > torque_eps);
  ends when the torque vanishes - light objects give too little torque and stop short.
variant slip: L = 1 while the object does not slip, 0 while it slips and for `slip_hold` ticks
  after the last slip felt, so the leak closes the grip again and the object turns in small
  slips. When the opening has stopped growing, or the object has not begun to turn at all, and it
  turns too slowly to reach the target in time (a grip firmer than usual: a slow skin's gentle grasp
  closes to the force limit), the opening grows towards `max_opening` (`Widening`). The hold matters with a real sensor: the pipeline's slip flickers while the object
  turns (frames in which it reads under the threshold), and opening on each such frame lets a
  light object drop.
"""

from __future__ import annotations

import math

from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, time_limit
from behaviours.skill_kit.control import LeakyIntegrator
from behaviours.skill_kit.hand import SteadyAngle, false_object, hand_torque, object_angle, total_slip
from behaviours.skill_kit.registry import register

GROWING = 0.05  # an opening that grew by this share of its span over a stall window is still growing


@register
class InHandRot(ProgramSkill):
    NAME = "in_hand_rot"
    SUMMARY = "let the held object turn under its own weight (leaky-integrator opening) to a target angle"
    PARAMS = {
        "variant": Param("str", "what drives the opening", "slip", choices=("torque", "slip")),
        "target": Param("float", "turn to stop at, from the starting orientation", 60.0, "deg", min=1.0, max=180.0),
        "alpha": Param("float", "leaky-integrator inertia (closer to 1 opens more slowly)", 0.99, min=0.0, max=0.999),
        "opening": Param("float", "largest opening beyond the starting width", 0.006, "m", min=0.0005, max=0.05),
        "torque_eps": Param("float", "torque variant: torque that counts as zero", 0.01, "px", min=0.0),
        "slip": Param("float", "slip variant: slip (both fingers) that counts as turning; the pipeline's slip "
                      "also lights up as the object turns in the image, so a turn alone should stay under it",
                      0.1, min=0.0),
        "slip_hold": Param("int", "slip variant: ticks after the last slip felt before the opening may grow again",
                           3, min=1),
        "max_opening": Param("float", "slip variant: the opening grows past `opening` up to this when the object "
                             "turns too slowly at it (a grip firmer than usual needs a wider opening)", 0.012, "m",
                             min=0.0005, max=0.05),
        "stall": Param("float", "slip variant: window over which a turn too slow to reach the target in time, at an "
                       "opening no longer growing, grows the opening by half of `opening`", 1.0, "s", min=0.1),
        "settle": Param("int", "torque variant: ticks of zero torque that end the rotation", 10, min=1),
        "max_time": time_limit(20.0),
        "force": Param("float", "gripper force when closing again", 40.0, "N", min=0.0, device="gripper_force"),
        "max_false_object": Param("float", "stop when a camera's colour model takes more than this share of the "
                                  "object's own seen area of the empty view for the object (pipeline's warning): "
                                  "a few per cent of false object skew the mask's orientation", 0.1, min=0.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.GRIPPER_WIDTH, keys.GRIPPER_FAULT, keys.GRIPPER_MOVING)
    NEEDS = ("pivot",)
    WRITES = (keys.OBJECT_ANGLE,)

    def program(self):
        gripper = self.cell.gripper
        angle = SteadyAngle()
        for look in range(angle.ticks):  # the start angle as steady as the angles the turn is judged by
            if look:
                yield
            left, right = self.tactile()
            seen = angle.update(object_angle(left, right))
            if seen is None:
                return self.fail("no object seen between the fingers to rotate")
            theta0, areas = seen, {"left": left.obj.area, "right": right.obj.area}
        blind = false_object((left, right), areas, self.p.max_false_object)
        if blind:
            return self.fail(blind)
        width0, start = self.gripper_width(), self.now()
        drive, quiet, turned, since_slip = LeakyIntegrator(self.p.alpha), 0, 0.0, self.p.slip_hold
        widen = Widening(self.p.opening, max(self.p.opening, self.p.max_opening), self.p.stall)
        while turned < self.p.target:
            left, right = self.tactile()
            blind = false_object((left, right), areas, self.p.max_false_object)
            if blind:
                yield from self.grip(width0, gripper.max_speed, self.p.force)  # stop the turn where it is
                return self.fail(blind)
            theta = angle.update(object_angle(left, right))
            if theta is None:
                return self.fail(f"the object fell out after turning {turned:.0f} deg: open more slowly "
                                 "(alpha closer to 1) or less far ('opening')")
            turned = math.degrees(abs(theta - theta0))
            if self.p.variant == "torque":
                twisting = abs(hand_torque(left, right)) > self.p.torque_eps
                quiet = 0 if twisting else quiet + 1
                if quiet >= self.p.settle:
                    yield from self.grip(width0, gripper.max_speed, self.p.force)
                    return self.fail(f"the torque vanished at {turned:.0f} deg, short of the target "
                                     f"{self.p.target:.0f} deg: too light for torque sensing, use variant: slip")
                drive_input = 1.0 if twisting else 0.0
            else:
                since_slip = 0 if total_slip(left, right) > self.p.slip else since_slip + 1
                drive_input = 0.0 if since_slip < self.p.slip_hold else 1.0
            opened = drive.step(-drive_input)  # 0 closed .. 1 fully opened, with inertia
            if self.p.variant == "slip":
                left_s = max(self.p.max_time - (self.now() - start), self.cell.clock.period)
                drive.x = opened = widen.update(self.now(), turned, opened, (self.p.target - turned) / left_s)
            gripper.move(width0 + opened * widen.span, speed=gripper.max_speed)
            if self.now() - start > self.p.max_time:
                yield from self.grip(width0, gripper.max_speed, self.p.force)
                return self.fail(f"turned only {turned:.0f} of {self.p.target:.0f} deg in "
                                 f"{self.p.max_time:.0f} s ({widen.span * 1000:.1f} mm opening): allow a larger "
                                 "'opening' or 'max_opening'")
            self.feedback_message = f"turned {turned:.1f} deg, {opened * widen.span * 1000:.1f} mm open"
            yield
        fault = yield from self.grip(width0, gripper.max_speed, self.p.force)  # stop the turn
        if fault:
            return self.fail(fault)
        theta = object_angle(*self.tactile())
        if theta is None:
            return self.fail(f"the object fell out while the fingers closed again at {turned:.0f} deg")
        turned = math.degrees(abs(theta - theta0))
        self.write(keys.OBJECT_ANGLE, turned)
        self.feedback_message = f"turned {turned:.1f} deg"
        return Status.SUCCESS


class Widening:
    """The slip variant's opening span (m), grown while the object turns too slowly at it: a grip
    firmer than the one `opening` was set for (a slow skin feels the contact late, so the gentle grasp
    closes to the gripper's force limit; 40 N instead of 30 N seen with a 0.75 s skin) still holds the
    object, or lets it creep, at the whole opening. Judged over windows of `stall` s: when the opening
    has stopped growing (at its span, or where the leak balances the slips felt) and the object turned
    less than the rate that would reach the target in the time left, the span grows by half of
    `opening`, up to `max_opening`, the opening's share scaled down so the fingers do not jump. An
    object that turns fast enough, or an opening still growing, leaves the span as it is, except
    while the object has not begun to turn (less than one window's worth of the needed rate in all):
    the grip then still holds it fully, and waiting for the slow integrator to creep to its span
    protects nothing (randomised pixel seed 1, a 0.75 s skin: 6 of its 20 s so, then 50 of 60 deg)."""

    def __init__(self, opening: float, max_opening: float, stall: float):
        self.span, self.step, self.max_span, self.stall = opening, 0.5 * opening, max_opening, stall
        self._mark: tuple[float, float, float] | None = None  # (time, turned, opened) the window began at

    def update(self, now: float, turned: float, opened: float, needed_rate: float) -> float:
        """This tick's share of the (maybe grown) span to open, from the integrator's `opened`;
        `needed_rate` (deg/s) is the turn rate that would reach the target in the time left."""
        if self._mark is None:
            self._mark = (now, turned, opened)
        since, turned0, opened0 = self._mark
        if now - since < self.stall:
            return opened
        self._mark = (now, turned, opened)
        too_slow = turned - turned0 < needed_rate * (now - since)
        # An opening still growing may yet loosen the grip enough, unless the object has not begun to
        # turn at all: while the grip holds it fully, opening slowly protects nothing.
        started = turned >= needed_rate * self.stall
        if (started and opened - opened0 >= GROWING) or not too_slow or self.span >= self.max_span:
            return opened
        grown = min(self.span + self.step, self.max_span)
        opened *= self.span / grown
        self.span = grown
        self._mark = (now, turned, opened)
        return opened
