"""Stirring a held stick through a substance: the 8 predefined movements (horizontal paths around
the starting point) and the loop that follows one and returns, shared by `stir` (StirLearn's
training trials) and `classify_substance`."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import ProgramSkill
from perception.learning.features import REST_TICKS, tick_features


def _circle(radius: float, period: float, sense: float = 1.0) -> Callable[[float], np.ndarray]:
    w = 2 * math.pi / period
    return lambda t: radius * np.array([math.cos(sense * w * t) - 1.0, math.sin(sense * w * t)])


def _line(amplitude: float, period: float, axis: int) -> Callable[[float], np.ndarray]:
    w = 2 * math.pi / period
    return lambda t: amplitude * math.sin(w * t) * np.eye(2)[axis]


def _eight(size: float, period: float) -> Callable[[float], np.ndarray]:
    w = 2 * math.pi / period
    return lambda t: size * np.array([math.sin(w * t), 0.5 * math.sin(2 * w * t)])


def _spiral(radius: float, period: float, duration: float) -> Callable[[float], np.ndarray]:
    w = 2 * math.pi / period
    return lambda t: radius * min(t / duration, 1.0) * np.array([math.cos(w * t), math.sin(w * t)])


# Offsets (m, base x and y) from the starting point as functions of time; all start at 0.
MOVEMENTS: dict[str, Callable[[float], np.ndarray]] = {
    "circle_small_slow": _circle(0.015, 2.0),
    "circle_small_fast": _circle(0.015, 1.0, -1.0),
    "circle_large_slow": _circle(0.03, 3.0),
    "circle_large_fast": _circle(0.03, 1.5, -1.0),
    "line_x": _line(0.025, 2.0, 0),
    "line_y": _line(0.025, 2.0, 1),
    "figure_eight": _eight(0.025, 3.0),
    "spiral": _spiral(0.03, 1.5, 4.0),
}
CYCLE = "cycle"
CORRECTION = 0.25  # share of the path-following error corrected per tick


def next_trial(previous: dict | None) -> int:
    return 0 if previous is None else previous["trial"] + 1


def stir_steps(skill: ProgramSkill, movement: str, duration: float, trial: int):
    """Hold the dipped stick still for REST_TICKS ticks, follow the movement for `duration` s with velocity
    commands and return to the start; yields once per tick and returns the per-tick feature rows
    felt at rest and while stirring (the rest rows first: what
    the sensor shows with nothing moving, its rest noise and its reading of the grip, against which
    StirLearn measures the stirring, since a lab never knows its sensor's gain and noise exactly).

    The command is the path's own velocity plus a share of the position error: correcting the
    whole error every tick would oscillate on a real controller, whose pose lags the command."""
    arm, dt = skill.cell.arm, skill.cell.clock.period
    start, path, rows = skill.pose(), MOVEMENTS[movement], []
    skill.write(keys.STIR_TRIAL, {"trial": trial, "movement": movement, "active": True})
    for _ in range(REST_TICKS):
        rows.append(tick_features(*skill.tactile()))
        skill.feedback_message = f"holding still before stirring ({movement})"
        yield
    t = 0.0
    while t < duration:
        rows.append(tick_features(*skill.tactile()))
        error = start[:2] + path(t) - skill.pose()[:2]
        velocity = (path(t + dt) - path(t)) / dt + CORRECTION * error / dt
        arm.speed_linear(np.r_[velocity, 0.0, 0.0, 0.0, 0.0])
        skill.feedback_message = f"stirring ({movement}), {t:.1f} of {duration:.1f} s"
        t += dt
        yield
    skill.write(keys.STIR_TRIAL, {"trial": trial, "movement": movement, "active": False})
    fault = yield from skill.move(start, 0.05)
    return rows, fault
