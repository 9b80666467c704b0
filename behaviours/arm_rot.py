"""ArmRot: turn the wrist about the fingers' closing axis in the sense of the torque the held
object puts on the fingers (estimated from the marker field), until that torque vanishes:
an asymmetric object then hangs with its centre of mass below the grasp.

A viscoelastic skin shows a load up to a second late, so the torque read while the wrist turns is
the torque of up to a second before: a wrist that stops at the first quiet reading overshoots
hanging by the turn of that second (12.8 deg on a 0.92 s skin in pixel mode). Once the torque has
stayed below `eps` for `settle` ticks the wrist therefore stands still and watches the reading
settle (`skill_kit.settle`: what is still to come, extrapolated from a `settle_window` window of
readings, measured on the spot; no time constant is read from the sensor profile). It ends when
the settled torque (the mean of the window's newest third plus what is still to come) is below `eps`,
and turns on as soon as that mean, or the torque it is settling towards, reaches `eps` (a mean: on a
noisy skin single readings cross eps at rest); the turns after a
stand start from rest at a small torque, so the lag carries them past hanging by little."""

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
from behaviours.skill_kit.settle import Settling


@register
class ArmRot(ProgramSkill):
    NAME = "arm_rot"
    SUMMARY = "rotate the arm until the in-finger torque of the held object goes to zero"
    PARAMS = {
        "gain": Param("float", "wrist speed per unit of torque", 2.0, "rad/s/px", min=0.0),
        "max_speed": Param("float", "wrist speed limit (the cell refuses turns over its max_angular_speed)", 0.6, "rad/s", min=0.01, max=1.0, device="arm_angular_speed"),
        "eps": Param("float", "torque that counts as zero", 0.02, "px", min=0.0),
        "settle": Param("int", "ticks the torque must stay below eps before the wrist stands to watch it settle", 5, min=1),
        "settle_window": Param("float", "window over which the standing wrist measures the torque's settling "
                               "(at least about the skin's time constant)", 1.0, "s", min=0.2),
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
        period = self.cell.clock.period
        window = max(6, round(self.p.settle_window / period))
        quiet, stand = 0, None
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
            if stand is not None:  # standing: the skin may not show the whole torque yet
                coming = stand.update(torque)
                if coming is None:
                    quiet, stand = 0, None  # more torque shows up, or will: turn on
                elif abs(coming) < self.p.eps:
                    break
            else:
                quiet = quiet + 1 if abs(torque) < self.p.eps else 0
                rate = float(np.clip(self.p.gain * torque, -self.p.max_speed, self.p.max_speed))
                arm.speed_linear(np.r_[0.0, 0.0, 0.0, rotation(pose)[:, 1] * rate])
                if quiet >= self.p.settle:
                    arm.stop()
                    stand = Stand(window, self.p.eps, period)
            self.feedback_message = (f"torque {torque:.3f} px, turned {turned:.1f} deg"
                                     + (", standing while the skin settles" if stand is not None else ""))
            yield
        arm.stop()
        turned = math.degrees(angle_between(start, self.pose()))
        self.write(keys.ARM_ROTATION, turned)
        self.feedback_message = f"torque vanished after turning {turned:.1f} deg"
        return Status.SUCCESS


class Stand:
    """The torque a standing wrist will settle at, watched tick by tick: `update` returns the settled
    torque once the relaxation still to come is within eps / 2 (`Settling`), NaN while it cannot
    tell yet, and None as soon as the mean of the newest third of the window, or the torque it is
    visibly settling towards, reaches `eps` (turn on)."""

    def __init__(self, window: int, eps: float, period: float):
        self.eps = eps
        self._settling = Settling(window, 0.5 * eps, period)
        self._recent: deque[float] = deque(maxlen=max(2, window // 3))

    def update(self, torque: float) -> float | None:
        self._recent.append(torque)
        settled = self._settling.update(torque)
        if len(self._recent) < (self._recent.maxlen or 0):
            return math.nan
        recent = float(np.mean(self._recent))  # a mean: one noisy reading over eps is no torque
        if abs(recent) >= self.eps:
            return None
        last = self._settling.last
        if last is None or not np.all(np.isfinite(last.remaining)):
            return math.nan
        coming = recent + float(last.remaining[0])
        if abs(coming) >= self.eps:
            return None
        return coming if settled else math.nan
