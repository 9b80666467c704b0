"""Find where the plate loads the element most: lift the foot clear, slide in under the plate,
slide along the span measuring the load through the fingers every tick, locate the peak
(smoothing + local quadratic fit), go there and set the foot back down."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours import keys
from behaviours.approach_plate import plate_of
from behaviours.base import Param, ProgramSkill, summed_force
from behaviours.load_search import locate_peak
from behaviours.registry import register


@register
class FindMaxLoad(ProgramSkill):
    NAME = "find_max_load"
    SUMMARY = "scan along the plate measuring the load in the grip and stop at its maximum"
    PARAMS = {
        "span": Param("vector", "part of the plate span to scan [from, to]", [0.1, 0.9], "fraction of span", length=2, min=0.0, max=1.0),
        "speed": Param("float", "sliding speed along the plate", 0.03, "m/s", min=0.001, max=0.2),
        "lift": Param("float", "foot lift off the ground while sliding", 0.003, "m", min=0.0, max=0.05),
        "smoothing": Param("float", "moving-average window along the plate", 0.03, "m", min=0.0),
        "fit_half_width": Param("float", "half width of the quadratic fit around the best sample", 0.08, "m", min=0.005),
        "min_load": Param("float", "a peak below this means the plate was never touched", 0.5, "px", min=0.0),
        "reference_ticks": Param("int", "ticks averaged for the unloaded reference", 10, min=1),
    }
    READS = (keys.ELEMENT, keys.PLATES, keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT,
             keys.ROBOT_MOVING)
    WRITES = (keys.LOAD_PROFILE, keys.BEST_POSE, keys.MEASURED_LOAD)

    @classmethod
    def validate(cls, params) -> None:
        lo, hi = params["span"]
        if lo >= hi:
            raise ValueError(f"span must run forward, got [{lo}, {hi}]")

    def program(self):
        element = self.read(keys.ELEMENT)
        plate = plate_of(element, self.read(keys.PLATES, {}))
        x0, span = float(plate["origin"][0]), float(plate["span"])
        start, end = (x0 + f * span for f in self.p.span)

        pose = self.pose()
        pose[2] += self.p.lift
        fault = yield from self.move(pose, 0.01)
        if fault:
            return self.fail(fault)
        f_ref = yield from self.mean_force(self.p.reference_ticks)

        pose[0], pose[1] = start, plate["origin"][1]
        self.feedback_message = "sliding in under the plate"
        fault = yield from self.move(pose, 0.05)
        if fault:
            return self.fail(fault)

        positions, loads = [], []

        def sample() -> None:
            left, right = self.tactile()
            # The plate pushes the upright element down its axis (image x of both fingers).
            positions.append(self.pose()[0] - x0)
            loads.append(-(summed_force(left, right) - f_ref)[0])
            self.feedback_message = f"scan at {positions[-1]:.3f} m, load {loads[-1]:.2f}"

        # Twice the time the scan should take, and a margin for the controller to get going.
        timeout = 2.0 * abs(end - start) / self.p.speed + 10.0
        fault = yield from self.move(np.r_[end, pose[1:]], self.p.speed, timeout, watch=sample)
        if fault:
            return self.fail(fault)

        peak = locate_peak(positions, loads, self.p.smoothing, self.p.fit_half_width)
        profile = {"plate": element["plate"], "position": np.array(positions), "load": np.array(loads),
                   "smoothed": peak.smoothed, "best_position": peak.position, "best_load": peak.load}
        self.write(keys.LOAD_PROFILE, profile)
        if peak.load < self.p.min_load:
            return self.fail(f"no load found along the plate (peak {peak.load:.2f} px < "
                             f"{self.p.min_load} px): the element never reached it")
        best = np.r_[x0 + peak.position, pose[1:]]
        fault = yield from self.move(best, self.p.speed)
        if fault:
            return self.fail(fault)
        best[2] -= self.p.lift
        fault = yield from self.move(best, 0.01)
        if fault:
            return self.fail(fault)
        self.write(keys.BEST_POSE, best)
        self.write(keys.MEASURED_LOAD, peak.load)
        self.feedback_message = f"max load {peak.load:.2f} px at {peak.position:.3f} m"
        return Status.SUCCESS
