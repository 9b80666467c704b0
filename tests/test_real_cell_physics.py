"""The physics a real cell has and the simulated one now models: a viscoelastic skin (lag, creep,
hysteresis) and a UR-class TCP force sensor (offset, drift, noise, zeroing); and the skills that
hold their accuracy across them (find_max_load scanning both ways, descend_until_contact zeroing
and measuring its sensors' noise)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from assembly.design.model import DesignModel
from assembly.testing import TreeHarness, mock_cell, touch
from assembly.testing.harness import RecordingArm
from drivers.safety import SafetyLimits
from drivers.sim.models.fingervision_model import FingerContact
from drivers.sim.models.force_sensor import ForceSensedArm, ForceSensorConfig
from drivers.sim.models.skin import Skin
from perception.sensor_profile import default_profile

DESIGN = DesignModel.load(Path(__file__).resolve().parents[1] / "trees" / "design" / "two_bays.json")
PLATES = DESIGN.plates()


def skin(**numbers) -> Skin:
    base = {"skin_lag_s": 0.0, "skin_creep_share": 0.0, "skin_creep_s": 0.0, "skin_hysteresis": 0.0}
    return Skin(dataclasses.replace(default_profile(), **{**base, **numbers}))


def felt_normal(s: Skin, loads: list[float], dt: float = 1 / 30) -> list[float]:
    return [s.feel(FingerContact(normal=load), i * dt).normal for i, load in enumerate(loads)]


def test_a_skin_without_lag_or_creep_hands_the_contact_on_unchanged():
    contact = FingerContact(normal=3.0)
    assert skin().feel(contact, 0.0) is contact


def test_the_skin_lags_a_step_load_by_its_time_constant():
    felt = felt_normal(skin(skin_lag_s=0.3), [10.0] * 31)
    assert felt[9] == pytest.approx(10.0 * (1 - math.exp(-1.0)), rel=1e-6)  # after 0.3 s: 63 %
    assert felt[30] == pytest.approx(10.0 * (1 - math.exp(-30 / 9)), rel=1e-6)


def test_the_skin_creeps_to_the_full_load_and_unloads_more_slowly():
    s = skin(skin_lag_s=0.1, skin_creep_share=0.2, skin_creep_s=2.0, skin_hysteresis=1.0)
    loading = felt_normal(s, [10.0] * 300)  # 10 s
    assert loading[15] == pytest.approx(8.0 + 2.0 * (1 - math.exp(-0.5 / 2.0)), rel=0.02)  # fast part done, creeping
    assert loading[-1] == pytest.approx(10.0, rel=0.01)
    unloading = [s.feel(FingerContact(normal=0.0), 10.0 + i / 30).normal for i in range(1, 16)]
    # 0.5 s after unloading the fast part has gone down by 1 - exp(-0.5 / 0.2), less than loading's 1 - exp(-5)
    assert unloading[-1] > 10.0 - loading[15] + 0.5


def test_the_force_sensor_reads_offset_and_noise_and_zeroing_removes_the_offset():
    cell = mock_cell()
    raw = cell.arm.inner
    sensed = ForceSensedArm(raw, cell.clock, ForceSensorConfig(offset=10.0, drift=0.0, noise=0.4), seed=1)
    readings = []
    for _ in range(200):
        readings.append(sensed.tcp_wrench()[:3])
        assert np.array_equal(sensed.tcp_wrench(), sensed.tcp_wrench())  # one value per tick
        cell.clock.advance()
    readings = np.array(readings)
    assert np.linalg.norm(readings.mean(axis=0)) == pytest.approx(10.0, abs=0.2)
    assert readings.std(axis=0) == pytest.approx([0.4] * 3, rel=0.2)
    sensed.zero_ft_sensor()
    cell.clock.advance()
    assert np.linalg.norm(sensed.tcp_wrench()[:3]) < 2.5  # the offset is gone; this tick's noise is not


def ground_cell(offset: float, noise: float):
    """A mocked cell whose arm force reads the ground 50 mm below the start (20 kN/m) through a TCP
    sensor with `offset` and `noise`; the fingertips feel nothing."""
    cell = mock_cell()
    raw = cell.arm.inner
    sensed = ForceSensedArm(raw, cell.clock, ForceSensorConfig(offset=offset, drift=0.5, noise=noise), seed=2)
    cell.arm = RecordingArm(sensed, SafetyLimits(), cell.clock)
    cell.zero_force_sensor = sensed.zero_ft_sensor
    ground = raw.pose()[2] - 0.05
    return cell, raw, ground


@pytest.mark.parametrize("offset", [0.0, 5.0, 10.0])
@pytest.mark.parametrize("noise", [0.4, 3.6])  # e-Series class, and the CB-series figure
def test_descend_finds_the_ground_through_an_offset_noisy_force_sensor(offset, noise):
    cell, raw, ground = ground_cell(offset, noise)
    h = TreeHarness.from_text("version: 1\nname: t\nroot: {skill: descend_until_contact, name: s, "
                              "params: {speed: 0.01, force_eps: 2.0}}\n", cell=cell)

    def script(tick, t):
        raw.external_wrench[2] = 20000.0 * max(0.0, ground - raw.pose()[2])
        return {}

    h.script(script)
    assert h.run_until_done(900).name == "SUCCESS"
    # 2 N floor (or 4 x the measured noise) at 20 kN/m: within a few tenths of a mm of the ground
    depth = ground - h.blackboard("/task/contact_pose")[2]
    assert 0.0 < depth < max(2.0, 4.0 * noise * math.sqrt(3)) / 20000.0 + 0.001


def lagging_plate(h, peak: float, lag: float, rng):
    """The scripted plate of test_skills_assembly, felt through a skin lagging `lag` s."""
    x0 = PLATES["P1"]["origin"][0]
    s = skin(skin_lag_s=lag)

    def script(tick, t):
        pose = h.arm.pose()
        under = abs(pose[1] - PLATES["P1"]["origin"][1]) < 0.1
        a = pose[0] - x0
        load = max(0.0, 20.0 * (1 - ((a - peak) / 0.35) ** 2)) if under else 0.0
        felt = s.feel(FingerContact(shear=np.array([load / 2, 0.0])), t).shear[0]
        noise = rng.normal(0, 0.2)
        return {"left": touch("left", shear=(felt + noise, 0.0)), "right": touch("right", shear=(-felt - noise, 0.0))}
    return script


@pytest.mark.parametrize("both_ways", [True, False])
def test_find_max_load_scanning_both_ways_cancels_the_skins_lag(both_ways):

    lag, speed = 1.0, 0.03
    h = TreeHarness.from_text("version: 1\nname: t\ncell: {tick_hz: 30}\nroot: {skill: find_max_load, name: s, "
                              f"params: {{speed: {speed}, both_ways: {str(both_ways).lower()}}}}}\n", cell=mock_cell())
    h.set("/task/element", DESIGN.element("E1"))
    h.set("/task/plates", PLATES)
    h.script(lagging_plate(h, 0.57, lag, np.random.default_rng(0)))
    assert h.run_until_done(9000).name == "SUCCESS"
    error = h.blackboard("/task/best_pose")[0] - PLATES["P1"]["origin"][0] - 0.57
    profile = h.blackboard("/task/load_profile")
    assert len(profile["position"]) == len(profile["load"]) == len(profile["smoothed"])  # plotted side by side
    if both_ways:
        assert abs(error) < 0.01
        assert h.blackboard("/task/load_profile")["lag_shift"] == pytest.approx(speed * lag, rel=0.3)
    else:  # one pass finds the peak about speed x lag late
        assert error == pytest.approx(speed * lag, rel=0.3)
