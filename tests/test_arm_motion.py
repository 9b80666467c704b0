"""The simulated arm as a UR controller moves it: a command takes effect after the latency, then the
TCP's velocity ramps within the acceleration limits (drivers/sim/devices/arm_motion.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from drivers.cell_builders import CellRequest
from drivers.cell_file import CellFileError
from drivers.clock import SimClock
from drivers.sim.cell import build_sim_cell
from drivers.sim.devices.arm import KinematicArm
from drivers.sim.devices.arm_motion import ArmMotion

HOME = [0.0, 0.0, 0.5, math.pi, 0.0, 0.0]
DT = 1 / 30
SIM_YAML = Path(__file__).resolve().parents[1] / "drivers" / "cells" / "sim.yaml"


def arm(**motion) -> KinematicArm:
    return KinematicArm(SimClock(DT), HOME, motion=ArmMotion(**motion))


def speeds(a: KinematicArm, ticks: int) -> list[float]:
    out = []
    for _ in range(ticks):
        a.step(DT)
        out.append(float(np.linalg.norm(a.tcp_speed()[:3])))
    return out


def test_a_twist_ramps_up_at_the_acceleration_after_the_latency():
    a = arm(acceleration=0.5, latency=0.008)
    a.speed_linear(np.array([0.2, 0, 0, 0, 0, 0]))
    assert a.is_moving()  # sent, not yet in effect: moving already counts
    v = speeds(a, 30)
    assert v[0] == pytest.approx(0.5 * (DT - 0.008))  # 8 ms late, then 0.5 m/s^2
    assert np.max(np.diff(v)) <= 0.5 * DT + 1e-9  # never faster than the limit
    assert v[-1] == pytest.approx(0.2)
    t = 30 * DT - 0.008  # time in motion: ramp 0.4 s, then cruise
    assert a.pose()[0] == pytest.approx(0.2 * 0.4 / 2 + 0.2 * (t - 0.4), abs=1e-6)


def test_a_linear_move_arrives_exactly_on_a_trapezoidal_profile():
    a = arm(acceleration=0.5, latency=0.008)
    target = np.array([0.1, 0.0, 0.5, math.pi, 0.0, 0.0])
    a.move_linear(target, 0.1)
    ticks = 0
    while a.is_moving():
        a.step(DT)
        ticks += 1
        assert ticks < 300
    # 0.1 m at 0.1 m/s with 0.2 s ramps each end: 1.2 s, plus the latency
    assert ticks * DT == pytest.approx(1.2 + 0.008, abs=DT)
    assert np.allclose(a.pose(), target) and not a.tcp_speed().any()


def test_a_stop_decelerates_and_the_braking_distance_says_how_far():
    a = arm(acceleration=0.5, stop_deceleration=2.0, latency=0.008)
    a.speed_linear(np.array([0.0, 0.25, 0, 0, 0, 0]))
    speeds(a, 40)
    y0 = a.pose()[1]
    a.stop()
    speeds(a, 30)
    assert not a.is_moving()
    travelled = a.pose()[1] - y0
    assert travelled == pytest.approx(0.25 * 0.008 + 0.25**2 / (2 * 2.0), rel=0.02)
    # the safety layer's look-ahead: a slower twist ramps down at the acceleration, not the stop's
    assert a.braking_distance(0.25) == pytest.approx(0.25 * 0.008 + 0.25**2 / (2 * 0.5))


def test_rotation_ramps_too_and_a_turning_move_ends_on_the_orientation():
    a = arm(angular_acceleration=0.5, latency=0.0)
    a.speed_linear(np.array([0, 0, 0, 0, 0, 0.3]))
    w = []
    for _ in range(30):
        a.step(DT)
        w.append(a.tcp_speed()[5])
    assert w[0] == pytest.approx(0.5 * DT) and w[-1] == pytest.approx(0.3)
    a = arm(acceleration=0.5, angular_acceleration=0.5, latency=0.008)
    turned = np.array([0.02, 0.0, 0.5, 0.0, 0.0, 0.0])
    turned[3:] = [math.pi * math.cos(0.2), math.pi * math.sin(0.2), 0.0]  # another orientation
    a.move_linear(turned, 0.1)
    for _ in range(200):
        a.step(DT)
    assert not a.is_moving() and np.allclose(a.pose(), turned)


def test_all_zero_is_the_kinematic_arm():
    a = arm(acceleration=0.0, angular_acceleration=0.0, stop_deceleration=0.0, latency=0.0)
    a.speed_linear(np.array([0.2, 0, 0, 0, 0, 0]))
    a.step(DT)
    assert a.pose()[0] == pytest.approx(0.2 * DT) and a.tcp_speed()[0] == pytest.approx(0.2)


def test_the_cell_file_arm_section_sets_the_motion_and_names_a_bad_field(tmp_path):
    data = yaml.safe_load(SIM_YAML.read_text())
    assert ArmMotion(**data["arm"]) == ArmMotion()  # the packaged cell states the documented defaults
    data["arm"] = {"latency": 0.02}
    cell = build_sim_cell(tmp_path / "c.yaml", data, CellRequest(tick_hz=30, scene="hold"))
    assert cell.arm.inner.motion == ArmMotion(latency=0.02)
    for bad in ({"latency": -1}, {"jerk": 3}):
        data["arm"] = bad
        with pytest.raises(CellFileError, match=r"arm"):
            build_sim_cell(tmp_path / "c.yaml", data, CellRequest(tick_hz=30, scene="hold"))
