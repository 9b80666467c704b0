"""Find where the plate loads the element most: lift the foot clear, slide in under the plate,
slide along the span and back measuring the load through the fingers every tick, locate the peak
of each pass (smoothing + local quadratic fit), go to their mean and set the foot back down.

Scanning both ways keeps the accuracy with a lagging skin: the load the markers show trails the
plate's by the skin's time constant, so each pass finds the peak about speed x lag past it along
its way, and the two shifts cancel in the mean (measured by `python -m assembly.bench.skin_lag`;
docs/physics.md has the figures). Half of their difference is written as the profile's `lag_shift`.

The scan is only trusted when the grip held and the profile peaks clearly. A grip that slips
under the plate's load caps the load the fingers feel, so the
profile flat-lines and its maximum means nothing; a peak at the end of the scan, or no higher
above the rest of the profile than the noise, is no maximum either. Either way the skill slides
back out, sets the foot on the ground, grasps firmer (`regrasp_squeeze` further, up to
`regrasp_force`) and scans again, at most `max_regrasps` times, then fails naming the element
rather than placing it at a bad point.

Slip is judged as a real sensor gives it: the pipeline's slip is image motion over the object,
so the markers moving under a noisy load light it up as well. Each tick counts the slip beyond
what the markers' own motion explains (`flow_gain`, `flow_saturation`: the pipeline's response, read
from the cell's sensor profile unless given), and the grip counts as slipping only when the
median of that (both fingers) over the last `slip_ticks` ticks exceeds `slip`: a sliding element
moves its texture on every tick, a load change only on a few. A grip
that gives way slowly stays under the slip noise; it shows in the profile instead, as a load
cut off at what the grip carries: a peak sharper than a plate's (`min_top_width`), or a reading
that falls below the unloaded reference once the element has shifted (`max_below`, a share of the
peak: a lagging skin shows a load late, and its creep and hysteresis leave it above the truth after
unloading, never below, so only the grip can take the reading under it). A slow skin makes this the
usual way to fail: its gentle grasp feels contact late and closes to the force limit, and that
firmer grip slips too slowly for the slip rule under the heaviest plates.

The fingers' reading must also follow the load up to its top. Where the cell has a TCP force sensor,
the arm feels the plate's push too (from a zero taken at rest before the scan, so the sensor's offset
and the element's weight do not count), linear but blind to the grip. Each pass fits the fingers'
response to that push on its flanks (20-60 % of the peak push); a top that falls short of it by more
than `max_shortfall` is a saturated reading (pixel mode under a firm grip loses the most displaced
markers, and the fingers' load went flat from 45 to 81 N), so the passes' peaks are located on the
arm's push instead (the profile's `measured_by`). The same push, as a median over `force_ticks`,
stops the scan beyond `max_scan_force`."""

from __future__ import annotations

import dataclasses
import statistics
from collections import deque
from typing import NamedTuple

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import hand, keys
from behaviours.skill_kit.base import Param, ProgramSkill, magnitude, summed_force
from behaviours.skill_kit.hand import slip_beyond_marker_flow
from behaviours.skill_kit.load_search import locate_peak, moving_average
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.sensor import sensor_profile
from behaviours.skill_kit.transit import plate_of
from perception.state import TactileState

FIRMER = "grasp firmer ('regrasp_force', 'max_regrasps')"


class Refusal(NamedTuple):
    """Why a scan's peak is not trusted (naming the rule) and what to change."""

    what: str
    fix: str

    def __str__(self) -> str:
        return f"{self.what}; {self.fix}"


@register
class FindMaxLoad(ProgramSkill):
    NAME = "find_max_load"
    SUMMARY = "scan along the plate measuring the load in the grip and stop at its maximum"
    PARAMS = {
        "span": Param("vector", "part of the plate span to scan [from, to], less where the element does not fit "
                      "(its half width plus `end_clearance` from each support): the default scans as near each "
                      "support as the element fits", [0.0, 1.0], "fraction of span", length=2, min=0.0, max=1.0),
        "end_clearance": Param("float", "room left between the element and a plate's support at each end of the "
                               "scan", 0.02, "m", min=0.0, max=0.5),
        "speed": Param("float", "sliding speed along the plate", 0.03, "m/s", min=0.001, max=0.2, device="arm_speed"),
        "lift": Param("float", "foot lift off the ground while sliding", 0.003, "m", min=0.0, max=0.05),
        "smoothing": Param("float", "moving-average window along the plate", 0.03, "m", min=0.0),
        "fit_half_width": Param("float", "half width of the quadratic fit around the best sample", 0.08, "m", min=0.005),
        "min_load": Param("float", "a peak below this means the plate was never touched", 0.5, "px", min=0.0),
        "reference_ticks": Param("int", "ticks averaged for the unloaded reference", 10, min=1),
        "slip": Param("float", "median slip (both fingers) over `slip_ticks` ticks that counts as the element "
                      "sliding in the grip", 0.1, min=0.0),
        "slip_ticks": Param("int", "ticks over which the slip's median is taken", 10, min=1),
        "flow_gain": Param("float", "slip the markers' own motion lights up, per px/frame of it and per unit of "
                           "seen object area (0: take the slip as it comes; default: the sensor profile's "
                           "slip_flow_gain)", None, min=0.0),
        "flow_saturation": Param("float", "marker motion beyond which the slip it lights up grows no more "
                                 "(default: the sensor profile's slip_flow_saturation)", None, "px", min=0.0),
        "min_top_width": Param("float", "least width of the profile's top (within 3 % of the peak, or 5 sigma of the smoothed noise), as a share of "
                               "the scan, for a peak at mid-span: a plate's load changes smoothly, so a sharper peak means "
                               "the grip gave way; a peak nearer a support may be narrower in proportion, as a beam's is",
                               0.08, min=0.0, max=1.0),
        "min_clarity": Param("float", "least peak prominence, in units of the load noise, of a trusted maximum",
                             5.0, min=0.0),
        "both_ways": Param("bool", "scan the span forth and back and take the mean of the two peaks: a "
                           "lagging skin shifts each pass's peak along its way by about speed x lag, and the "
                           "mean cancels it (false: one pass, half the time)", True),
        "max_below": Param("float", "a smoothed profile that falls below the unloaded reference by more than this share "
                           "of its peak measured a grip that shifted under the load, not the plate: a plate only "
                           "pushes, and a lagging skin shows a load late but never below what it carries (intact "
                           "grips on 0.3-0.9 s skins dipped at most 1 % of the peak, shifted ones 14-48 %)", 0.1,
                           min=0.0),
        "max_shortfall": Param("float", "share by which the fingers' load at the top of a pass may fall short of what "
                               "their gain on the pass's flanks (fingers against the arm's push, 20-60 % of its peak) "
                               "gives for the arm's peak push: more means the fingers' reading saturated (the pixel "
                               "pipeline's under a heavy load), the top of their profile is flat and its maximum "
                               "is noise, so the peaks are taken from the arm's push profile (needs a force sensor; "
                               "fingers reading in proportion on 0.03-1 s skins fell short by at most 2 % in "
                               "signals mode, 4 % in pixel mode under light plates; pixel mode's compressed ones "
                               "under a firm grip by 14-29 %)", 0.1, min=0.0, max=1.0),
        "min_push": Param("float", "least peak of the arm's push profile for the checks made on it (the fingers' "
                          "saturation, rule 'max_below' on the push; a cell without a force sensor reads 0 N: "
                          "no check)", 10.0, "N", min=0.0),
        "max_regrasps": Param("int", "firmer re-grasps and rescans before giving up", 1, min=0, max=5),
        "regrasp_squeeze": Param("float", "further closing at each re-grasp", 0.01, "m", min=0.0005, max=0.03),
        "regrasp_force": Param("float", "gripper force limit of a re-grasp", 80.0, "N", min=1.0, device="gripper_force"),
        "touch_eps": Param("float", "force change that means the foot touched the ground before a re-grasp",
                           0.5, "px", min=0.0),
        "max_scan_force": Param("float", "push the arm may feel while scanning before the scan stops: the TCP force's "
                                "change from its mean at rest before the scan (the element hanging, so neither the "
                                "sensor's offset nor the element's weight counts), its median over `force_ticks` ticks "
                                "(0: no check; cells without a force sensor read 0 N)", 100.0, "N", min=0.0,
                                device="arm_force"),
        "force_ticks": Param("int", "ticks over which the push's median is taken against `max_scan_force`: a plate's "
                             "load is noisy by a few % of it, so one reading over the limit is no push over it",
                             7, min=1),
    }
    READS = (keys.ELEMENT, keys.PLATES, keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT,
             keys.ROBOT_MOVING, keys.ROBOT_WRENCH, keys.GRIPPER_WIDTH, keys.GRIPPER_OBJECT, keys.GRIPPER_FAULT, keys.GRIPPER_MOVING)
    NEEDS = ("plates",)
    WRITES = (keys.LOAD_PROFILE, keys.LOAD_SCAN, keys.BEST_POSE, keys.MEASURED_LOAD)
    _range: tuple[float, float] = (0.0, 1.0)  # the scan's part of the plate (fractions of its span), set by `scan`
    _span: float = 1.0  # m, the plate's span, set by `scan`

    @classmethod
    def validate(cls, params) -> None:
        lo, hi = params["span"]
        if lo >= hi:
            raise ValueError(f"span must run forward, got [{lo}, {hi}]")

    def scan_range(self, element: dict, span: float) -> tuple[float, float]:
        """The part of the plate to scan, as fractions of its `span`: the `span` param less where the
        element (its larger cross dimension) does not fit with `end_clearance` to spare from each
        support; ValueError when nothing is left."""
        margin = (max(element["size"][1], element["size"][2]) / 2.0 + self.p.end_clearance) / span
        lo, hi = max(self.p.span[0], margin), min(self.p.span[1], 1.0 - margin)
        if hi - lo < 0.05:
            raise ValueError(f"the element fits only between {margin:.3f} and {1.0 - margin:.3f} of the {span:g} m "
                             f"plate's span, which leaves no room to scan 'span' {list(self.p.span)} (with "
                             f"end_clearance {self.p.end_clearance:g} m); widen 'span' or lower 'end_clearance'")
        return lo, hi

    def least_top_width(self, peak_along: float) -> float:
        """The least top width (share of the scan) of a peak `peak_along` of the span (0..1):
        `min_top_width` at mid-span, scaled by the peak's distance to the nearer support over half
        the span (a beam's load top narrows towards a support)."""
        return self.p.min_top_width * min(1.0, max(0.0, min(peak_along, 1.0 - peak_along)) / 0.5)

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        hand.warm_up()  # the compiled marker motion loaded now, not on the scan's first tick

    def program(self):
        profile = sensor_profile(self.cell)
        self._flow = (profile.slip_flow_gain if self.p.flow_gain is None else self.p.flow_gain,
                      profile.slip_flow_saturation if self.p.flow_saturation is None else self.p.flow_saturation)
        element = self.read(keys.ELEMENT)
        plate = plate_of(element, self.read(keys.PLATES, {}))
        outside = self.pose()  # beside the plate, foot on the ground
        for attempt in range(self.p.max_regrasps + 1):
            if attempt:
                fault = yield from self.regrasp(outside, attempt)
                if fault:
                    return self.fail(f"element {element['id']}: re-grasp {attempt} failed: {fault}")
            peak, problem, firmer_helps = yield from self.scan(element, plate)
            if not problem:
                break
            if not firmer_helps:  # the arm stopped, or the plate was never touched
                return self.fail(f"element {element['id']}: {problem}")
        else:
            tried = f" after {self.p.max_regrasps} firmer re-grasps" if self.p.max_regrasps else ""
            what, fix = problem if isinstance(problem, Refusal) else (problem, "")
            return self.fail(f"element {element['id']}: {what}{tried}; not placing it at a bad point"
                             + (f"; {fix}" if fix else ""))
        x0 = float(plate["origin"][0])
        best = np.r_[x0 + peak.position, self.pose()[1:]]
        fault = yield from self.move(best, self.p.speed)
        if fault:
            return self.fail(fault)
        best[2] -= self.p.lift
        fault = yield from self.move(best, 0.01)
        if fault:
            return self.fail(fault)
        self.write(keys.BEST_POSE, best)
        self.write(keys.MEASURED_LOAD, peak.load)
        regrasps = f" after {attempt} re-grasp{'s' * (attempt > 1)}" if attempt else ""
        self.feedback_message = f"max load {peak.load:.2f} px at {peak.position:.3f} m{regrasps}"
        return Status.SUCCESS

    def scan(self, element: dict, plate: dict):
        """Lift the foot, slide in and scan the span; returns (peak, problem, whether a firmer
        grip could help), problem None for a trusted peak."""
        x0, span = float(plate["origin"][0]), float(plate["span"])
        try:
            self._range = self.scan_range(element, span)
        except ValueError as exc:
            return None, str(exc), False
        self._span = span
        start, end = (x0 + f * span for f in self._range)
        pose = self.pose()
        pose[2] += self.p.lift
        fault = yield from self.move(pose, 0.01)
        if fault:
            return None, fault, False
        f_ref, push_zero = yield from self.at_rest(self.p.reference_ticks)

        pose[0], pose[1] = start, plate["origin"][1]
        self.feedback_message = "sliding in under the plate"
        fault = yield from self.move(pose, 0.05)
        if fault:
            return None, fault, False

        positions: list[float] = []
        loads: list[float] = []
        recent: deque[float] = deque(maxlen=self.p.slip_ticks)
        pushes: deque[float] = deque(maxlen=self.p.force_ticks)
        arm_loads: list[float] = []  # the arm's push down the element's axis (N), sampled with `loads`
        slipped = [False]
        last: list[tuple[TactileState, TactileState] | None] = [None]  # the fingertips of the tick before
        held = self.gripper_object()  # the fingers were stopped on the element: losing that flag is losing it
        # Written once; the lists grow as the scan goes, so a live view can draw the profile growing.
        self.write(keys.LOAD_SCAN, {"plate": element["plate"], "position": positions, "load": loads})

        def sample() -> str | None:
            left, right = self.tactile()
            # The plate pushes the upright element down its axis (image x of both fingers; -z of the base).
            positions.append(self.pose()[0] - x0)
            loads.append(-(left.force[0] + right.force[0] - f_ref[0]))
            push = np.asarray(self.read(keys.ROBOT_WRENCH)[:3], dtype=float) - push_zero
            arm_loads.append(-float(push[2]))
            before = last[0] or (left, right)
            last[0] = (left, right)
            recent.append(slip_beyond_marker_flow(left, before[0], *self._flow)
                          + slip_beyond_marker_flow(right, before[1], *self._flow))
            slipped[0] = len(recent) == recent.maxlen and statistics.median(recent) > self.p.slip
            self.feedback_message = f"scan at {positions[-1]:.3f} m, load {loads[-1]:.2f}"
            if slipped[0]:
                return f"the element slipped in the grip at {positions[-1]:.3f} m along the plate"
            if held and not self.gripper_object():
                return (f"the element was lost from the grip at {positions[-1]:.3f} m along the plate (the "
                        "gripper no longer reports an object between its fingers)")
            pushes.append(magnitude(push))
            felt = statistics.median(pushes)
            if 0.0 < self.p.max_scan_force < felt:
                return (f"the arm felt a push of {felt:.1f} N at {positions[-1]:.3f} m along the plate (median "
                        f"of {len(pushes)} ticks, from its reading at rest), over max_scan_force "
                        f"{self.p.max_scan_force:g} N")
            return None

        # Twice the time a pass should take, and a margin for the controller to get going.
        timeout = 2.0 * abs(end - start) / self.p.speed + 10.0
        passes = [(start, end), (end, start)] if self.p.both_ways else [(start, end)]
        found: list = []
        smoothed: list[np.ndarray] = []  # each pass's smoothed load, in the order it was sampled
        stretches: list[slice] = []
        for a, b in passes:
            first = len(positions)
            if a != start:
                self.feedback_message = "scanning back"
            stopped = yield from self.move(np.r_[b, pose[1:]], self.p.speed, timeout, watch=sample)
            peak, problem, firmer_helps = self.judge(element, positions[first:], loads[first:], stopped, slipped[0],
                                                     arm_loads[first:])
            if problem:
                return peak, problem, firmer_helps
            found.append(peak)
            smoothed.append(in_sampled_order(positions[first:], peak.smoothed))
            stretches.append(slice(first, len(positions)))
        shortfall = max(self.shortfall(positions[s], peak, arm_loads[s]) for s, peak in zip(stretches, found))
        measured_by = "fingers"
        if shortfall > self.p.max_shortfall:  # the fingers' top is flat: the arm's push locates the peaks
            measured_by = "arm"
            found = [dataclasses.replace(peak, position=locate_peak(positions[s], arm_loads[s], self.p.smoothing,
                                                                    self.p.fit_half_width).position)
                     for s, peak in zip(stretches, found)]
        if len(found) == 2:  # the skin's lag shifts each pass's peak along its way: the mean cancels it
            forward, back = found
            peak = dataclasses.replace(forward, position=0.5 * (forward.position + back.position),
                                       load=0.5 * (forward.load + back.load))
            lag_shift = 0.5 * (forward.position - back.position)
        else:
            peak, lag_shift = found[0], 0.0
        self.write(keys.LOAD_PROFILE, {
            "plate": element["plate"], "position": np.array(positions), "load": np.array(loads),
            "smoothed": np.concatenate(smoothed), "best_position": peak.position, "best_load": peak.load,
            "clarity": min(p.clarity for p in found), "top_share": max(p.top_share for p in found),
            "grip_slipped": False, "passes": len(found), "lag_shift": lag_shift,
            "arm_load": np.array(arm_loads), "shortfall": shortfall, "measured_by": measured_by})
        return peak, None, False

    def shortfall(self, positions: list[float], peak, arm_loads: list[float]) -> float:
        """Share by which one pass's finger load falls short at its top of what the fingers' response
        measured on the pass's flanks gives for the arm's peak push: a straight line (finger load
        against the arm's push) fitted where the arm feels 20-60 % of its peak (an offset as well as a
        gain: a lagging, creeping skin reads late and stays above zero after unloading, on each flank
        the other way) and taken to the arm's peak. About 0 (or below) for fingers that read the load
        in proportion, large for a saturated reading; 0 when the arm felt less than `min_push` (no
        force sensor, or too light a plate to tell)."""
        arm = self.smoothed_push(positions, arm_loads)
        if arm is None:
            return 0.0
        top = float(arm.max())
        flanks = (arm > 0.2 * top) & (arm < 0.6 * top)
        if flanks.sum() < 5 or np.ptp(arm[flanks]) < 0.2 * top:
            return 0.0
        gain, offset = np.polyfit(arm[flanks], peak.smoothed[flanks], 1)
        if gain <= 0.0:
            return 0.0
        return max(0.0, 1.0 - (float(peak.smoothed.max()) - offset) / (gain * top))

    def smoothed_push(self, positions: list[float], arm_loads: list[float]) -> np.ndarray | None:
        """The arm's push along one pass in ascending position order, smoothed as the fingers' load is
        (`smoothing`); None when it peaks below `min_push` (no force sensor, or too light a plate)."""
        order = np.argsort(np.asarray(positions, dtype=float))
        span = float(positions[order[-1]] - positions[order[0]])
        arm = moving_average(np.asarray(arm_loads, dtype=float)[order],
                             max(1, round(self.p.smoothing * (len(order) - 1) / max(span, 1e-9))))
        return arm if float(arm.max()) >= self.p.min_push else None

    def at_rest(self, ticks: int):
        """(summed finger force, TCP force) averaged over the next `ticks` ticks, the element hanging
        clear of everything: the zeros the scan's load and push are measured from (a real TCP force
        sensor reads an offset and drifts, so the push is taken from a zero measured on the spot)."""
        fingers, arm = np.zeros(3), np.zeros(3)
        for _ in range(ticks):
            yield
            fingers += summed_force(*self.tactile())
            arm += np.asarray(self.read(keys.ROBOT_WRENCH, np.zeros(6))[:3], dtype=float)
        return fingers / ticks, arm / ticks

    def judge(self, element: dict, positions: list[float], loads: list[float], stopped: str | None,
              slipping: bool, arm_loads: list[float]):
        """One pass's (peak, problem, whether a firmer grip could help), problem None for a trusted
        peak; a pass with a problem writes its load profile (a trusted one is written with the scan's)."""
        if stopped and not slipping or len(positions) < 5:
            return None, stopped or "the scan ended at once", slipping
        peak = locate_peak(positions, loads, self.p.smoothing, self.p.fit_half_width)
        verdict = self.verdict(peak, stopped, slipping, self.smoothed_push(positions, arm_loads))
        if verdict[1] is not None:
            self.write(keys.LOAD_PROFILE, {
                "plate": element["plate"], "position": np.array(positions), "load": np.array(loads),
                "smoothed": in_sampled_order(positions, peak.smoothed), "best_position": peak.position,
                "best_load": peak.load, "clarity": peak.clarity, "top_share": peak.top_share,
                "grip_slipped": verdict[3]})
        return verdict[:3]

    def verdict(self, peak, stopped: str | None, slipping: bool, push: np.ndarray | None = None):
        """(peak, problem, whether a firmer grip could help, whether the grip slipped) of a located
        peak (and the arm's smoothed `push` profile, None without a force sensor); a problem names the
        rule that refused the peak and what to change."""
        min_top = self.least_top_width(peak.sample_position / self._span)
        sharp = not slipping and peak.clarity >= self.p.min_clarity and peak.top_share < min_top
        # A plate only pushes, and a lagging skin only shows a load late (creep and hysteresis leave it
        # above the truth after unloading, never below): a profile that falls below its unloaded
        # reference by more than `max_below` of its peak measured a grip that shifted under the load.
        drifted = not slipping and float(peak.smoothed.min()) < -self.p.max_below * abs(peak.load)
        # The same holds for the arm's push, which has no lag: pulled up below its zero at rest, the
        # element stands on the ground, slid down in the grip (pixel mode may barely show it in the fingers).
        grounded = (not slipping and not drifted and push is not None
                    and float(push.min()) < -self.p.max_below * float(push.max()))
        drifted = drifted or grounded
        slipped = slipping or sharp or drifted
        if slipping:
            return peak, Refusal(f"{stopped} (rule 'slip')", FIRMER), True, slipped
        if peak.load < self.p.min_load:
            return peak, Refusal(f"no load found along the plate (rule 'min_load': peak {peak.load:.2f} px < "
                                 f"{self.p.min_load} px): the element never reached it",
                                 "check the element's length and the plate's height"), False, slipped
        if peak.clarity < self.p.min_clarity:
            return (peak, *self._unclear(peak), slipped)
        if sharp:
            return peak, Refusal(f"the element slipped in the grip at {peak.sample_position:.3f} m along the plate: the "
                                 f"load peaked there more sharply than a plate can (rule 'min_top_width': top "
                                 f"{peak.top_share:.0%} of the scan wide < {min_top:.1%} there)",
                                 f"{FIRMER}, or, if this plate's maximum is that sharp, lower 'min_top_width'"), True, slipped
        if grounded and push is not None:
            return peak, Refusal(f"the element shifted in the grip during the scan: the arm's push fell to "
                                 f"{push.min():.1f} N, below its zero at rest by more than {self.p.max_below:g} of "
                                 f"its peak {push.max():.1f} N, the element's foot on the ground (rule 'max_below': "
                                 "a plate only pushes)", FIRMER), True, slipped
        if drifted:
            return peak, Refusal(f"the element shifted in the grip during the scan: the load fell to "
                                 f"{peak.smoothed.min():.2f} px, below its unloaded reference by more than "
                                 f"{self.p.max_below:g} of its peak {peak.load:.2f} px (rule 'max_below': a plate "
                                 "only pushes)", FIRMER), True, slipped
        return peak, None, False, slipped

    def _unclear(self, peak) -> tuple[Refusal, bool]:
        """Why a peak is not clear enough (rule 'min_clarity') and what to change, and whether a
        firmer grip could help: not when the load is still high at an end of the scan (the maximum
        may lie beyond it, or the profile has no room to fall on that side)."""
        low, high = (f * self._span for f in self._range)
        smoothed = peak.smoothed
        at_end = [where for where, value, x in (("start", smoothed[0], low), ("end", smoothed[-1], high))
                  if value > 0.5 * float(smoothed.max()) and abs(peak.sample_position - x) <= 0.25 * (high - low)]
        unclear = (f"no clear maximum along the plate (rule 'min_clarity': the peak at {peak.sample_position:.3f} m "
                   f"stands {peak.clarity:.1f} times the load noise above the rest of the profile, needs "
                   f"{self.p.min_clarity:g})")
        if at_end:
            return Refusal(f"{unclear}: the load is still high at the scan's {' and '.join(at_end)} "
                           f"([{self._range[0]:.3f}, {self._range[1]:.3f}] of the span), so the maximum is near a "
                           "support and the scan cannot see the load fall on that side",
                           "scan closer to the plate's end ('span', 'end_clearance') or lower 'min_clarity'"), False
        return Refusal(unclear, f"{FIRMER}, or lower 'min_clarity'"), True

    def regrasp(self, outside: np.ndarray, attempt: int):
        """Slide back out from under the plate and along it to where the first scan came in from
        (`outside`), set the foot on the ground so it carries the element, and close the fingers
        further with a higher force limit; None, or why not. Going back outside the plate keeps the
        rescan's slide-in where the plate carries little, as the first one was: straight from where
        a pass stopped, it would cut under the plate's loaded middle sideways."""
        self.feedback_message = f"re-grasp {attempt}: sliding out from under the plate"
        out = self.pose()
        out[1] = outside[1]
        fault = yield from self.move(out, 0.05)
        if fault:
            return fault
        out[0] = outside[0]
        fault = yield from self.move(out, 0.05)
        if fault:
            return fault
        f_ref = yield from self.mean_force(self.p.reference_ticks)
        touched = []

        def ground() -> str | None:
            change = magnitude(summed_force(*self.tactile()) - f_ref)
            if change > self.p.touch_eps:
                touched.append(change)
                return "foot on the ground"
            return None

        self.feedback_message = f"re-grasp {attempt}: setting the foot down"
        fault = yield from self.move(out - [0.0, 0.0, 0.05, 0.0, 0.0, 0.0], 0.01, watch=ground)
        if not touched:
            return fault or "the foot did not touch the ground within 50 mm"
        self.feedback_message = f"re-grasp {attempt}: closing with up to {self.p.regrasp_force:.0f} N"
        speed = self.p.regrasp_squeeze / 0.5  # over half a second
        return (yield from self.grip(self.gripper_width() - self.p.regrasp_squeeze, speed, self.p.regrasp_force))


def in_sampled_order(positions: list[float], by_position: np.ndarray) -> np.ndarray:
    """Values `locate_peak` gives in ascending position order, put back in the order the positions
    were sampled (a pass scanning back samples them descending)."""
    out = np.empty(len(positions))
    out[np.argsort(np.asarray(positions, dtype=float))] = by_position
    return out
