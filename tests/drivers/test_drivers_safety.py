"""The safety layer around the kinematic arm: workspace, speed cap, force cap, watchdogs, faults."""

from __future__ import annotations

import time

import numpy as np
import pytest
from drivers_testkit import DEADLINE, wait_until

from drivers.clock import SimClock, WallClock
from drivers.protocols import DriverFault
from drivers.safety import SafeArm, SafetyLimits
from drivers.sim.devices.arm import KinematicArm

HOME = np.array([0.0, 0.0, 0.5, np.pi, 0.0, 0.0])
BOX = {"workspace_min": [-0.5, -0.5, 0.1], "workspace_max": [0.5, 0.5, 0.8]}


def make(clock=None, **limits) -> tuple[SafeArm, KinematicArm, SimClock]:
    clock = clock or SimClock(0.01)
    arm = KinematicArm(clock, HOME)
    return SafeArm(arm, SafetyLimits(**{**BOX, **limits}), clock), arm, clock


def run(safe: SafeArm, arm: KinematicArm, clock: SimClock, seconds: float) -> None:
    for _ in range(round(seconds / clock.period)):
        arm.step(clock.period)
        clock.advance()
        safe.kick()
        safe.supervise()


class RecordingArm(KinematicArm):
    """The kinematic arm, remembering the last command it was given."""

    def move_linear(self, pose, speed):
        self.last = ("move_linear", np.array(pose), speed)
        super().move_linear(pose, speed)

    def speed_linear(self, twist):
        self.last = ("speed_linear", np.array(twist))
        super().speed_linear(twist)


def test_out_of_box_target_is_clamped_into_the_workspace():
    safe, arm, clock = make()
    safe.move_linear(np.array([0.9, -0.2, 0.0, np.pi, 0, 0]), 0.2)
    run(safe, arm, clock, 5.0)
    assert np.allclose(arm.pose()[:3], [0.5, -0.2, 0.1])
    assert safe.clamped == 1 and safe.fault() is None


def test_out_of_box_target_is_refused_when_the_cell_says_so():
    safe, arm, clock = make(out_of_workspace="refuse")
    safe.move_linear(np.array([0.0, 0.0, 0.05, np.pi, 0, 0]), 0.2)
    run(safe, arm, clock, 0.5)
    assert np.allclose(arm.pose(), HOME)  # never moved
    assert "outside the box" in safe.fault()
    safe.move_linear(HOME + [0.1, 0, 0, 0, 0, 0], 0.1)  # latched: further commands refused too
    run(safe, arm, clock, 0.5)
    assert np.allclose(arm.pose(), HOME)


def test_speed_is_capped_for_moves_and_twists():
    clock = SimClock(0.01)
    arm = RecordingArm(clock, HOME)
    safe = SafeArm(arm, SafetyLimits(**BOX, max_speed=0.1), clock)
    safe.move_linear(HOME + [0.3, 0, 0, 0, 0, 0], 2.0)
    assert arm.last[2] == 0.1
    safe.speed_linear(np.array([0.3, 0.4, 0.0, 0.0, 0.0, 0.2]))
    twist = arm.last[1]
    assert np.linalg.norm(twist[:3]) == pytest.approx(0.1)
    assert np.allclose(twist[:3] / np.linalg.norm(twist[:3]), [0.6, 0.8, 0.0])  # direction kept
    assert twist[5] == 0.2


def test_twist_never_drives_out_through_a_face_of_the_box():
    safe, arm, clock = make()
    safe.move_linear(np.array([0.0, 0.0, 0.1, np.pi, 0, 0]), 0.25)
    run(safe, arm, clock, 3.0)
    safe.speed_linear(np.array([0.05, 0.0, -0.05, 0, 0, 0]))
    run(safe, arm, clock, 0.5)
    assert arm.pose()[2] == pytest.approx(0.1) and arm.pose()[0] == pytest.approx(0.025)


def test_a_held_twist_stops_at_each_face_it_would_cross():
    """Commanded once and held (as descend_until_contact does), a twist is checked every control
    period one period ahead: each component that would cross a face is dropped there."""
    safe, arm, clock = make()
    safe.speed_linear(np.array([0.05, 0.0, -0.05, 0, 0, 0]))
    lowest = HOME[2]
    for _ in range(2000):  # 20 s: the twist would go 1 m down and 1 m along x
        run(safe, arm, clock, clock.period)
        lowest = min(lowest, arm.pose()[2])
    assert 0.1 <= lowest < 0.1 + 0.05 * clock.period + 1e-12
    assert 0.5 - 0.05 * clock.period < arm.pose()[0] <= 0.5
    assert not arm.is_moving() and safe.fault() is None
    assert safe.held_at == "x max 0.5 m" and safe.clamped == 2


def test_a_held_twist_about_to_leave_the_box_is_a_fault_when_the_cell_refuses():
    safe, arm, clock = make(out_of_workspace="refuse")
    safe.speed_linear(np.array([0.0, 0.0, -0.2, 0, 0, 0]))
    run(safe, arm, clock, 5.0)
    assert 0.1 <= arm.pose()[2] < 0.1 + 0.2 * clock.period + 1e-12
    assert "would take the TCP" in safe.fault() and "through the box's z min 0.1 m" in safe.fault()
    assert not arm.is_moving()


class BrakingArm(KinematicArm):
    """A kinematic arm that declares the distance a real one needs to brake (0.5 m/s^2)."""

    def braking_distance(self, speed: float) -> float:
        return speed * speed / (2 * 0.5)


def test_the_look_ahead_adds_the_braking_distance_the_arm_declares():
    clock = SimClock(0.01)
    arm = BrakingArm(clock, HOME)
    safe = SafeArm(arm, SafetyLimits(**BOX), clock)
    safe.speed_linear(np.array([0.0, 0.0, -0.2, 0, 0, 0]))
    run(safe, arm, clock, 5.0)
    braking = 0.2 ** 2 / (2 * 0.5)  # 40 mm: a real arm would need that much to stop from 0.2 m/s
    assert 0.1 + braking - 0.2 * clock.period <= arm.pose()[2] < 0.1 + braking + 0.2 * clock.period


def test_force_above_the_cap_stops_and_latches():
    safe, arm, _ = make(max_force=50.0)
    safe.speed_linear(np.array([0, 0, -0.01, 0, 0, 0]))
    arm.external_wrench[:] = [0, 0, 80.0, 0, 0, 0]
    assert "force limit: 80.0 N > 50.0 N" in safe.supervise()
    assert not arm.is_moving()
    arm.external_wrench[:] = 0.0
    assert safe.supervise() is not None  # latched until a person resets it
    safe.reset()
    assert safe.supervise() is None


def test_tick_watchdog_fires_when_the_tree_stops_kicking():
    safe, arm, clock = make(watchdog_timeout=0.2)
    safe.speed_linear(np.array([0.02, 0, 0, 0, 0, 0]))
    for _ in range(30):  # the tree hangs: the cell still steps, nobody kicks
        arm.step(clock.period)
        clock.advance()
        safe.supervise()
    assert safe.fault().startswith("watchdog: tree has not ticked")
    assert not arm.is_moving()


def test_stale_arm_state_stops_the_arm():
    safe, arm, clock = make(stale_after=0.05)
    arm.state_stamp = lambda: 0.0  # the arm's data stopped arriving at t = 0
    safe.speed_linear(np.array([0.02, 0, 0, 0, 0, 0]))
    run(safe, arm, clock, 0.1)
    assert "stale arm state" in safe.fault() and not arm.is_moving()


def test_driver_fault_stops_and_a_raising_driver_does_not_crash_the_tick():
    safe, arm, _ = make()
    arm.fault_text = "protective stop"
    assert "driver fault: protective stop" in safe.supervise()

    safe, arm, _ = make()

    def broken(*_):
        raise DriverFault("link lost")

    arm.move_linear = broken
    safe.move_linear(HOME, 0.1)
    assert "driver fault during move_linear: link lost" in safe.fault()


def test_watchdog_thread_stops_the_arm_when_the_tick_loop_hangs():
    clock = WallClock(0.01)
    safe, arm, _ = make(clock=clock, watchdog_timeout=0.1)
    safe.start_watchdog(period=0.005)
    try:
        time.sleep(0.15)  # the cell is built but the tree has not started: nothing may trip yet
        assert safe.fault() is None
        safe.speed_linear(np.array([0.02, 0, 0, 0, 0, 0]))
        hung_at = clock.now()
        safe.kick()  # the last tick: no more ticks, no supervise() calls from the loop
        assert wait_until(lambda: safe.fault() is not None, DEADLINE)
        assert safe.fault().startswith("watchdog")
        assert not arm.is_moving()
        assert clock.now() - hung_at >= 0.1
    finally:
        safe.stop_watchdog()


def test_kick_feeds_a_controller_watchdog_unless_faulted():
    class ControllerArm(KinematicArm):
        kicks = 0

        def kick_watchdog(self):
            self.kicks += 1

    clock = SimClock(0.01)
    arm = ControllerArm(clock, HOME)
    safe = SafeArm(arm, SafetyLimits(**BOX), clock)
    safe.kick()
    safe.kick()
    safe.trip("test")
    safe.kick()
    assert arm.kicks == 2


def test_limits_are_validated():
    with pytest.raises(ValueError, match="out_of_workspace"):
        SafetyLimits(out_of_workspace="ignore")
    with pytest.raises(ValueError, match="unknown safety limit"):
        SafetyLimits.from_dict({"max_sped": 1.0})


def test_a_scaled_wall_clock_runs_cell_time_faster_and_ticks_on_its_boundaries():
    clock = WallClock(0.1, time_scale=20.0)  # 100 ms ticks of cell time, 5 ms of wall time
    started = time.monotonic()
    for _ in range(10):
        clock.advance()  # sleeps to the next boundary, so never short of it
    assert clock.now() >= 1.0
    assert time.monotonic() - started >= 10 * 0.1 / 20.0
    with pytest.raises(ValueError, match="positive"):
        WallClock(0.1, time_scale=0.0)
