"""skill_kit.settle: the rest of a lagging skin's answer, extrapolated from a window of readings
(Aitken over three stretches), on seeded synthetic first-order answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from behaviours.skill_kit.settle import Settling, reading_noise, relaxation

PERIOD = 1.0 / 30.0


def answer(tau: float, step: np.ndarray, ticks: int, noise: float = 0.0, seed: int = 0) -> np.ndarray:
    """A first-order skin answering a load `step` at tick 0, one reading a tick, with white noise."""
    t = np.arange(ticks)[:, None] * PERIOD
    rng = np.random.default_rng(seed)
    return step * (1.0 - np.exp(-t / tau)) + rng.normal(0.0, noise, (ticks, len(step)))


@pytest.mark.parametrize("tau", [0.3, 0.9, 1.5])
def test_extrapolates_the_rest_of_a_first_order_answer_and_its_time_constant(tau):
    step = np.array([0.0, 0.3, -0.6])
    readings = answer(tau, step, 45)  # 1.5 s of answer, window the last 30 ticks
    r = relaxation(readings[-30:], PERIOD)
    truth = step * math.exp(-44 * PERIOD / tau)
    # exact up to the pessimism of the noise margin (the answer's curvature reads as a little noise)
    assert np.all(np.abs(r.remaining) >= np.abs(truth)) and r.size <= 1.25 * float(np.linalg.norm(truth))
    assert r.lag == pytest.approx(tau, rel=1e-6)


def test_noise_alone_leaves_nothing_to_come():
    readings = answer(0.5, np.zeros(3), 30, noise=0.05, seed=3)
    r = relaxation(readings, PERIOD)
    assert r.size == 0.0 and r.lag is None
    assert r.noise == pytest.approx(0.05, rel=0.3)


def test_a_steady_ramp_never_settles():
    readings = np.arange(30)[:, None] * np.array([0.0, 0.0, -0.01])
    assert math.isinf(relaxation(readings, PERIOD).size)
    settling = Settling(30, 0.05, PERIOD)
    assert not any(settling.update(x) for x in readings)


def test_settling_says_steady_once_the_rest_is_within_the_tolerance_despite_noise():
    """A 0.9 s skin with 0.6 px still to show, read with 0.03 px of noise: steady when about 0.05 px
    is left (within the noise's reach of it), not before, and long before the answer is over."""
    tau, step = 0.9, np.array([0.1, 0.2, -0.55])
    readings = answer(tau, step, 300, noise=0.03, seed=7)
    settling = Settling(30, 0.05, PERIOD)
    first = next(i for i, x in enumerate(readings) if settling.update(x))
    left = float(np.linalg.norm(step)) * math.exp(-first * PERIOD / tau)
    assert 0.02 < left < 0.1
    assert first * PERIOD < 5 * tau


def test_refuses_too_short_a_window():
    with pytest.raises(ValueError, match="at least 6"):
        relaxation(np.zeros((5, 3)), PERIOD)
    with pytest.raises(ValueError, match="at least 6"):
        Settling(5, 0.1, PERIOD)


def test_reading_noise_ignores_a_slow_drift_and_one_sudden_step():
    rng = np.random.default_rng(5)
    drift = answer(0.9, np.array([0.5, -0.5, 0.2]), 30, noise=0.04, seed=5)
    assert reading_noise(drift) == pytest.approx(0.04, rel=0.35)
    stepped = rng.normal(0.0, 0.04, (12, 3))
    stepped[8:] += 3.0  # a tug between two ticks
    assert reading_noise(stepped) == pytest.approx(0.04, rel=0.5)
    settling = Settling(30, 0.05, PERIOD)
    for x in stepped[:5]:
        settling.update(x)
    assert settling.noise is None
    settling.update(stepped[5])
    assert settling.noise == pytest.approx(0.04, rel=0.6)
