"""GentleGrasp: close the gripper in small steps until the marker field changes on enough
markers (the object is touched), then squeeze a set margin so the grip carries the task loads.
A marker counts as changed beyond `threshold`, or beyond `noise_factor` times the rest noise the
first frames show when the skin (or that marker) is noisier than that (`ForceChangeDetector`).

A slow skin shows the touch late, so the fingers have closed past it when contact is felt. With
`settle_time` > 0 (off by default) they stop there while the skin settles (`skill_kit.settle`, up
to `settle_time`); the settled reading against the one at the stop and the decay's time constant,
both measured on the spot, say how far they closed past where the skin the squeeze was tuned on (the sensor profile's lag) would have
stopped them (`skill_kit.grasp_lag`), and the squeeze is taken from there. On a skin no slower than
that it is nothing, and the grasp only waits for the settling window (0.4 s)."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, time_limit
from behaviours.skill_kit.control import ForceChangeDetector
from behaviours.skill_kit.grasp_lag import overshoot
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.sensor import sensor_profile
from behaviours.skill_kit.settle import Settling
from perception.wrench import marker_forces

# Frames the marker field is taken at rest as the fingers start closing (a third of a second at 30 Hz,
# 5 mm of closing at the default step): enough to see each marker's own noise, which a filtered
# pixel pipeline's wander and a few noisy markers make larger than three frames show.
REFERENCE_FRAMES = 10
SETTLE_WINDOW_S = 0.4  # s of readings a settling judgement spans (three stretches of ~0.13 s)
MIN_LAGS = 3  # judgements that measured a decay before a lag counts as measured
SETTLED_SHARE = 0.1  # the skin has settled when what is still to come is below this share of the reading


@register
class GentleGrasp(ProgramSkill):
    NAME = "gentle_grasp"
    SUMMARY = "close step by step until FingerVision feels contact, then add a holding squeeze"
    PARAMS = {
        "step": Param("float", "gripper closing step per tick", 0.0005, "m", min=1e-5, max=0.01),
        "threshold": Param("float", "per-marker force change that counts as touched", 0.3, "px", min=0.0),
        "min_markers": Param("int", "markers that must change for contact", 10, min=1),
        "noise_factor": Param("float", "a marker counts only beyond this many times the rest noise measured "
                              "before closing (when that is above `threshold`)", 4.0, min=0.0),
        "squeeze": Param("float", "extra closing after contact, for a firm hold", 0.005, "m", min=0.0, max=0.02),
        "force": Param("float", "gripper force limit", 40.0, "N", min=0.0, device="gripper_force"),
        "min_width": Param("float", "width at which closing gives up (nothing grasped)", 0.002, "m", min=0.0, device="gripper_width"),
        "max_time": time_limit(20.0, "give up when no contact is felt within this time"),
        "settle_time": Param("float", "longest wait, fingers stopped at the felt touch, for the skin to show "
                             "all of it (a slow skin's overshoot is measured meanwhile; 0: no wait, the default until the demos' "
                             "tests are settled with it, see docs/robustness.md)", 0.0, "s",
                             min=0.0, max=30.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.GRIPPER_WIDTH, keys.GRIPPER_FAULT, keys.GRIPPER_MOVING)
    WRITES = (keys.GRASP_WIDTH,)

    def program(self):
        gripper = self.cell.gripper
        detector = ForceChangeDetector(self.p.threshold, self.p.min_markers, REFERENCE_FRAMES, self.p.noise_factor)
        speed, start, open_width = self.p.step / self.cell.clock.period, self.now(), self.gripper_width()
        while True:
            left, right = self.tactile()
            forces = (marker_forces(left.markers, "left"), marker_forces(right.markers, "right"))
            if detector.update(*forces):
                break
            width = self.gripper_width()
            if width <= self.p.min_width:
                return self.fail(f"closed to {width * 1000:.1f} mm without feeling an object")
            fault = self.gripper_fault()
            if fault:
                return self.fail(f"gripper fault: {fault}")
            if self.now() - start > self.p.max_time:
                gripper.stop()
                return self.fail(f"no contact felt within {self.p.max_time:.0f} s; the fingers stand at "
                                 f"{width * 1000:.1f} mm: are they blocked, or is FingerVision blind?")
            gripper.move(width - self.p.step, speed, self.p.force)
            self.feedback_message = f"closing, {detector.changed} markers moved over {detector.limit:.2f} px"
            yield
        felt = self.gripper_width()
        late = yield from self._late_by(detector, float(np.linalg.norm(detector.deviation(*forces))), speed)
        contact = min(felt + late, open_width)
        fault = yield from self.grip(contact - self.p.squeeze, speed, self.p.force)
        if fault:
            return self.fail(fault)
        self.write(keys.GRASP_WIDTH, contact)
        self.feedback_message = (f"contact at {contact * 1000:.1f} mm" + (
            f" (felt at {felt * 1000:.1f} mm: the skin showed it late)" if late > 0.0 else ""))
        return Status.SUCCESS

    def _late_by(self, detector: ForceChangeDetector, shown: float, speed: float):
        """Steps (`yield from`) with the fingers stopped at the felt touch until the skin has settled
        (or `settle_time`); returns how far (m) they closed past where the profile's skin would have
        stopped them (`grasp_lag.overshoot`), 0 without a measurable lag."""
        if self.p.settle_time <= 0.0 or shown <= 0.0:
            return 0.0
        self.cell.gripper.stop()
        period = self.cell.clock.period
        settling = Settling(max(6, round(SETTLE_WINDOW_S / period)), SETTLED_SHARE * shown, period)
        lags: list[float] = []
        reading = shown
        t0 = self.now()
        while self.now() - t0 < self.p.settle_time:
            yield
            left, right = self.tactile()
            seen = detector.deviation(marker_forces(left.markers, "left"), marker_forces(right.markers, "right"))
            reading = float(np.linalg.norm(seen))
            done = settling.update(seen)
            last = settling.last
            if last is not None and last.lag is not None:
                lags.append(last.lag)
            self.feedback_message = f"touch felt; waiting for the skin to settle ({reading:.2f} px)"
            if done:
                break
        last = settling.last
        settled = reading + (last.size if last is not None and np.isfinite(last.size) else 0.0)
        # A skin that settled within the first judgements is quicker than the window resolves
        # (~0.13 s a stretch): no lag measured, nothing taken back.
        lag = float(np.median(lags)) if len(lags) >= MIN_LAGS else None
        return overshoot(shown, settled, lag, speed, sensor_profile(self.cell).skin_lag_s)
