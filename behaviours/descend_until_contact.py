"""Lower the held element until FingerVision feels the ground, or the arm's own force readback
(contact is then felt even if the fingertip stream froze).

Neither sensor is trusted to read zero or to be still: before moving, the skill stands for
`reference_ticks` and takes each one's mean there as its zero (for the arm's TCP force this is the
zeroing a real UR needs: it reads several newtons of pose- and payload-dependent offset; a cell
that offers `zero_force_sensor` is zeroed first, as ur_rtde's zeroFtSensor does) and its rest
noise; that zero is written for a press that follows (`/task/force_zero`: a zeroing folds one noisy
reading into the sensor's zero, the mean over the reference ticks does not). Contact is a change beyond `noise_factor` times that noise, and never less than `eps`
(px) or `force_eps` (N). The fingertips are read along their surfaces (shear, summed over both):
a held object touching down is pushed along the fingers, while the closing axis carries the grip.
Each marker's force is compared with its own reference, averaged over the markers tracked now: under
a firm grip the markers are spread by several px, and the mean force over whichever markers happen
to be tracked moves by a few tenths of a px as the tracker loses and finds them; per-marker changes
do not (`skill_kit.marker_shift`)."""

from __future__ import annotations

from collections import deque

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, magnitude
from behaviours.skill_kit.marker_shift import MarkerShift
from behaviours.skill_kit.registry import register
from perception.state import TactileState


@register
class DescendUntilContact(ProgramSkill):
    NAME = "descend_until_contact"
    SUMMARY = "move down until the finger force changes by more than its measured noise allows"
    PARAMS = {
        "speed": Param("float", "descent speed", 0.01, "m/s", min=1e-4, max=0.1, device="arm_speed"),
        "eps": Param("float", "least fingertip force change that means contact", 0.5, "px", min=0.0),
        "max_travel": Param("float", "give up after descending this far (or at the workspace box's "
                            "floor, whichever comes first)", 0.15, "m", min=0.0, max=1.0),
        "reference_ticks": Param("int", "ticks at rest measuring both sensors' baseline, drift and noise", 15,
                                 min=3),
        "smoothing": Param("int", "ticks in the running median of the fingertip force (a marker lost for a "
                           "tick moves the mean force of a firm grip by a few tenths of a px)", 5, min=1),
        "noise_factor": Param("float", "a change must exceed this many times the measured rest noise", 4.0,
                              min=0.0),
        "force_eps": Param("float", "least change of the arm's measured TCP force that also means contact "
                           "(0: fingertips only)", 2.0, "N", min=0.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_WRENCH)
    NEEDS = ("surface",)
    WRITES = (keys.CONTACT_POSE, keys.FORCE_ZERO)

    def program(self):
        arm = self.cell.arm
        zero = getattr(self.cell, "zero_force_sensor", None)
        if zero is not None:  # a cell that can zero its TCP force sensor does so; the baseline below stays
            zero()
        shift = MarkerShift()
        references: list[tuple[TactileState, TactileState]] = []
        wrenches = []
        for _ in range(self.p.reference_ticks):
            yield
            references.append(self.tactile())
            shift.add_reference(*references[-1])
            wrenches.append(np.array(self.read(keys.ROBOT_WRENCH)[:3], dtype=float))
        forces = [along_surfaces(shift.change(*states)) for states in references]
        f0, finger_noise = rest_level(running_median(np.array(forces), self.p.smoothing))
        w0, arm_noise = rest_level(np.array(wrenches))
        eps = max(self.p.eps, self.p.noise_factor * finger_noise)
        force_eps = max(self.p.force_eps, self.p.noise_factor * arm_noise) if self.p.force_eps > 0.0 else 0.0
        recent = deque(forces[-self.p.smoothing:], maxlen=self.p.smoothing)
        start_z = self.pose()[2]
        arm.speed_linear(np.array([0.0, 0.0, -self.p.speed, 0.0, 0.0, 0.0]))
        while True:
            yield
            left, right = self.tactile()
            recent.append(along_surfaces(shift.change(left, right)))
            change = magnitude(np.median(np.array(recent), axis=0) - f0)
            felt = magnitude(self.read(keys.ROBOT_WRENCH)[:3] - w0)
            pose = self.pose()
            travelled = start_z - pose[2]
            self.feedback_message = (f"down {travelled * 1000:.1f} mm, |f - f0| = {change:.2f} px (contact at "
                                     f"{eps:.2f}), arm force change {felt:.2f} N (contact at {force_eps:.1f})")
            if change > eps or 0.0 < force_eps < felt:
                arm.stop()
                self.write(keys.CONTACT_POSE, pose)
                self.write(keys.FORCE_ZERO, w0.tolist())
                return Status.SUCCESS
            fault = self.arm_fault()
            if fault:
                return self.fail(f"arm fault: {fault}")
            if travelled > self.p.max_travel:
                arm.stop()
                return self.fail(f"no contact within {self.p.max_travel} m of descent")
            held = self.held_at_box()
            if held:
                arm.stop()
                return self.fail(f"no contact after {travelled * 1000:.0f} mm of descent, at the workspace "
                                 f"box's {held}: the safety layer stops the arm there")


def rest_level(samples: np.ndarray) -> tuple[np.ndarray, float]:
    """(mean, rms distance from it) of (n, 3) readings at rest: a sensor's zero and noise."""
    mean = samples.mean(axis=0)
    return mean, float(np.sqrt(np.mean(np.sum((samples - mean) ** 2, axis=1))))


def along_surfaces(force: np.ndarray) -> np.ndarray:
    """The components of a finger-convention hand force along the fingers' surfaces (image x and y)."""
    return force[[0, 2]]


def running_median(samples: np.ndarray, n: int) -> np.ndarray:
    """Median of each run of `n` consecutive rows of `samples` (all of them if there are fewer)."""
    n = min(n, len(samples))
    return np.array([np.median(samples[i:i + n], axis=0) for i in range(len(samples) - n + 1)])
