"""The skin response fit (assembly/skin_response.py) on responses made with known time constants:
the lag and hysteresis come back, and a creep is reported only when there is one to tell apart."""

from __future__ import annotations

import numpy as np
import pytest

from assembly.skin_response import fit, shown
from perception.sensor_profile import SensorProfile, default_profile

DT = 1.0 / 30.0


def press_and_hold(seed: int, lag: float, hysteresis: float, creep_share: float = 0.0, creep_s: float = 0.0,
                   noise_px: float = 0.006) -> tuple[np.ndarray, np.ndarray]:
    """2 N, 8 N for 8 s, 2 N for 8 s on a scale with 0.1 N of noise; the markers 0.085 px/N of the
    skin's shown load with their own noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(17.0 / DT)) * DT
    load = np.where((t >= 1.0) & (t < 9.0), 8.0, 2.0)
    markers = 0.3 + 0.085 * shown(load, DT, lag, hysteresis, creep_share, creep_s) + rng.normal(0, noise_px, len(t))
    return load + rng.normal(0.0, 0.1, len(t)), markers


@pytest.mark.parametrize("lag", [0.033, 0.1, 0.5, 1.0, 2.0])
def test_a_lag_without_creep_comes_back_and_no_creep_is_claimed(lag):
    got = fit(*press_and_hold(int(lag * 1000), lag, 0.3), DT)
    assert got.lag_s == pytest.approx(lag, rel=0.1)
    assert got.hysteresis == pytest.approx(0.3, abs=0.15)
    assert got.creep_share is None and got.creep_s is None and not got.creep_told_apart
    assert got.gain == pytest.approx(0.085, rel=0.05)


def test_a_creep_well_above_the_noise_is_told_apart():
    got = fit(*press_and_hold(3, 0.3, 0.5, creep_share=0.2, creep_s=4.0), DT)
    assert got.creep_told_apart
    assert got.lag_s == pytest.approx(0.3, rel=0.1)
    assert got.creep_share == pytest.approx(0.2, abs=0.04)
    assert got.creep_s == pytest.approx(4.0, rel=0.3)
    assert got.residual_px < got.lag_only_residual_px


def test_too_short_a_record_is_refused():
    with pytest.raises(ValueError, match=">= 20"):
        fit([1.0] * 5, [0.0] * 5, DT)


def test_a_profile_without_a_skin_gets_the_default_skin():
    """The profile schema's skin defaults are the default profile's skin (a lab's profile written
    before its response was measured gets that skin, not an instant one)."""
    named, bare = default_profile(), SensorProfile()
    assert (bare.skin_lag_s, bare.skin_creep_share, bare.skin_creep_s, bare.skin_hysteresis) == \
        (named.skin_lag_s, named.skin_creep_share, named.skin_creep_s, named.skin_hysteresis)
