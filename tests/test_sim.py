"""The simulated cell's models against closed-form and worked-out figures."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.clock import SimClock
from drivers.sim.devices.arm import KinematicArm
from drivers.sim.devices.gripper import SimGripper
from drivers.sim.models.plate import BeamPlate
from drivers.sim.transforms import matrix_to_rotvec, rotvec_to_matrix


def test_plate_finds_the_maximum_of_the_toy_scene():
    # L = 1, EI = 50, w = 100, k = 2000, P = 40 at 0.7: R(a) peaks at 43.1 N, 0.568 m from the left
    plate = BeamPlate(span=1.0, EI=50.0, w=100.0, P=40.0, c=0.7, k=2000.0)
    a, r = plate.max_load(clearance=0.0)
    assert a == pytest.approx(0.568, abs=0.001) and r == pytest.approx(43.1, abs=0.05)


def test_rigid_prop_at_midspan_carries_five_eighths_of_the_load():
    plate = BeamPlate(span=2.0, EI=80.0, w=50.0, P=0.0, k=1e12)
    assert plate.carried_force(1.0, 0.0) == pytest.approx(5 * 50.0 * 2.0 / 8, rel=1e-6)


def test_uniform_load_midspan_deflection():
    plate = BeamPlate(span=1.5, EI=60.0, w=70.0, P=0.0)
    assert plate.deflection(0.75) == pytest.approx(5 * 70.0 * 1.5**4 / (384 * 60.0))


def test_no_load_where_the_clearance_is_not_closed():
    plate = BeamPlate()
    assert plate.carried_force(0.02, 0.02) == 0.0


def test_arm_moves_at_the_commanded_speed_and_stops_on_target():
    clock = SimClock(0.01)
    arm = KinematicArm(clock, [0, 0, 0.5, np.pi, 0, 0])
    arm.move_linear(np.array([0.1, 0, 0.5, np.pi, 0, 0]), 0.05)
    for _ in range(100):
        arm.step(0.01)
    assert arm.pose()[0] == pytest.approx(0.05)
    for _ in range(101):
        arm.step(0.01)
    assert arm.pose()[0] == pytest.approx(0.1) and not arm.is_moving()


def test_arm_caps_commanded_speed():
    arm = KinematicArm(SimClock(0.1), [0, 0, 0.5, 0, 0, 0], max_speed=0.2)
    arm.speed_linear(np.array([1.0, 0, 0, 0, 0, 0]))
    arm.step(0.1)
    assert arm.pose()[0] == pytest.approx(0.02)


def test_gripper_settles_where_the_gel_squeeze_matches_the_force():
    g = SimGripper(max_width=0.085, gel_stiffness=5000.0)
    g.object_width = 0.04
    g.move(0.0, speed=0.1, force=20.0)
    for _ in range(200):
        g.step(0.01)
    assert g.object_detected() and g.squeeze_force() == pytest.approx(20.0)
    assert g.width() == pytest.approx(0.04 - 20.0 / 5000.0)


def test_rotation_helpers_round_trip():
    rng = np.random.default_rng(3)
    for r in [*rng.normal(size=(50, 3)), np.array([np.pi, 0, 0]), np.array([0, -np.pi / 2, 0])]:
        m = rotvec_to_matrix(r)
        assert np.allclose(m @ m.T, np.eye(3))
        assert np.allclose(rotvec_to_matrix(matrix_to_rotvec(m)), m, atol=1e-7)
