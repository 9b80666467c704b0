"""The UR driver and the unmodified ur_rtde client against the controller emulator (loopback)."""

from __future__ import annotations

import contextlib
import threading

import numpy as np
import pytest
import rtde_control
import rtde_receive
from drivers_testkit import next_host, wait_until

from drivers.hardware.ur import UrArm, UrConfig
from drivers.protocols import DriverFault
from drivers.safety import SafeArm, SafetyLimits

HOME = np.array([0.0, -0.4, 0.4, np.pi, 0.0, 0.0])
WATCHDOG_HZ = 4.0  # controller watchdog: 250 ms without a tick stops the program (slack for busy CI)


@pytest.fixture
def ur(start_ur):
    return start_ur("--contact-z", "0.2")


@pytest.fixture
def arm(ur, clock):
    a = UrArm(UrConfig(ur.host, watchdog_hz=WATCHDOG_HZ), clock)
    yield a
    a.close()


def ticking(arm: UrArm, predicate, timeout: float) -> bool:
    """Poll `predicate` while kicking the watchdog like the runner does each tick."""
    def check() -> bool:
        arm.kick_watchdog()
        return predicate()
    return wait_until(check, timeout, step=1 / 30)


def drive(arm: UrArm, timeout: float) -> bool:
    """Tick until the arm stops moving; False on timeout."""
    return ticking(arm, lambda: not arm.is_moving(), timeout)


def test_unmodified_ur_rtde_clients_connect_with_their_default_recipes(ur):
    receive = rtde_receive.RTDEReceiveInterface(ur.host)  # the full default output recipe
    control = rtde_control.RTDEControlInterface(ur.host)
    try:
        assert control.isProgramRunning()
        assert np.allclose(receive.getActualTCPPose(), HOME)
        assert receive.getRobotMode() == 7 and not receive.isProtectiveStopped()
        t0 = receive.getTimestamp()
        assert wait_until(lambda: receive.getTimestamp() > t0 + 0.05, 1.0)
        target = [0.05, -0.4, 0.35, np.pi, 0.0, 0.0]
        assert control.moveL(target, 0.5, 1.2)  # blocking moveL: returns once "done"
        assert np.allclose(ur.state()["pose"], target, atol=1e-9)
        control.stopScript()
    finally:
        control.disconnect()
        receive.disconnect()


def test_linear_move_is_asynchronous_and_reaches_the_target(arm, ur):
    target = HOME + [0.1, 0.05, -0.1, 0, 0, 0]
    arm.move_linear(target, 0.25)
    assert arm.is_moving()
    assert drive(arm, 3.0)
    assert np.allclose(arm.pose(), target, atol=1e-6)
    assert np.allclose(ur.state()["pose"], target, atol=1e-9)
    assert arm.fault() is None


def test_speed_command_then_stop_leaves_the_arm_at_rest(arm, ur):
    arm.speed_linear(np.array([0.05, 0, 0, 0, 0, 0]))
    assert ticking(arm, lambda: abs(ur.state()["velocity"][0] - 0.05) < 1e-9, 1.0)
    arm.stop()
    assert ur.state()["velocity"] == [0.0] * 6
    assert arm.fault() is None


def test_servo_streaming_for_one_second_at_the_controller_rate(arm, ur):
    assert arm.control_rate == 500.0  # e-Series emulator
    before = ur.state()["servo_updates"]
    start = arm.pose()
    latencies = arm.stream_servo(lambda t: start + [0.02 * t, 0, 0, 0, 0, 0], duration=1.0)
    s = ur.state()
    received = s["servo_updates"] - before
    rate = (received - 1) / (s["servo_last"] - s["servo_first"])  # on the emulator's clock
    assert len(latencies) >= 400 and received >= 0.95 * len(latencies)
    assert rate > 0.8 * arm.control_rate, f"streamed at {rate:.0f} Hz"
    # the arm tracked the stream (servoL lags its target by about the lookahead time, 0.1 s)
    assert 0.015 < s["pose"][0] - start[0] <= 0.02 + 1e-9


def test_move_until_contact_stops_on_the_contact_plane(arm, ur):
    arm.move_until_contact(np.array([0, 0, -0.1, 0, 0, 0]), timeout=10.0)
    assert arm.is_moving()
    assert drive(arm, 8.0)
    assert arm.fault() is None
    assert abs(arm.pose()[2] - 0.2) < 1e-9
    assert any("contact" in e for _, e in ur.state()["events"])
    arm.move_linear(HOME, 0.25)  # the control script still takes commands afterwards
    assert drive(arm, 5.0) and np.allclose(arm.pose(), HOME, atol=1e-6)


def test_controller_watchdog_stops_the_arm_when_the_tree_stops_ticking(arm, ur):
    assert ur.state()["watchdog_hz"] == 0.0  # not armed until the tree starts ticking
    arm.speed_linear(np.array([0, 0.02, 0, 0, 0, 0]))
    arm.kick_watchdog()
    assert ur.state()["watchdog_hz"] == WATCHDOG_HZ
    # no more kicks: the controller must stop the program within 1/WATCHDOG_HZ s
    assert wait_until(lambda: not ur.state()["program_running"], 1.0)
    assert wait_until(lambda: ur.state()["velocity"] == [0.0] * 6, 1.0)
    events = ur.state()["events"]
    assert any("RTDE watchdog" in e and "stopped" in e for _, e in events)
    assert wait_until(lambda: arm.fault() is not None, 0.5)
    assert "control script stopped" in arm.fault()


@contextlib.contextmanager
def moving_and_ticking(arm: UrArm, clock):
    """A SafeArm driving at 2 cm/s while a background 'tree' ticks at 30 Hz (kick + supervise),
    as the runner would, so the controller watchdog stays fed until something else happens."""
    safe = SafeArm(arm, SafetyLimits(), clock)
    safe.speed_linear(np.array([0, 0.02, 0, 0, 0, 0]))
    safe.kick()  # the first tick arms the controller watchdog
    done = threading.Event()

    def tick() -> None:
        while not done.wait(1 / 30):
            safe.kick()
            safe.supervise()

    ticker = threading.Thread(target=tick, daemon=True)
    ticker.start()
    try:
        assert safe.supervise() is None
        yield safe
    finally:
        done.set()
        ticker.join(timeout=2.0)


@pytest.fixture
def safe(arm, clock):
    with moving_and_ticking(arm, clock) as s:
        yield s


def test_protective_stop_is_detected_within_100ms_latched_and_never_unlocked(arm, ur, safe):
    injected = ur.call("protective_stop")["t"]
    assert wait_until(lambda: arm.fault() is not None, 1.0)
    assert arm.fault_at - injected < 0.100, f"detected after {arm.fault_at - injected:.3f} s"
    assert "protective stop" in arm.fault() and "never unlocks" in arm.fault()
    assert wait_until(lambda: "protective stop" in (safe.supervise() or ""), 0.5)
    safe.move_linear(HOME, 0.1)  # refused: nothing reaches the controller
    s = ur.state()
    assert s["velocity"] == [0.0] * 6 and s["protective_stopped"]
    assert not any("unlock" in e for _, e in s["events"])
    with pytest.raises(DriverFault, match="refused"):
        arm.move_linear(HOME, 0.1)


def test_dropped_connection_is_detected_within_100ms_and_the_arm_stops(arm, ur, safe):
    injected = ur.call("drop 2")["t"]
    assert wait_until(lambda: arm.fault() is not None, 1.0)
    assert arm.fault_at - injected < 0.100, f"detected after {arm.fault_at - injected:.3f} s"
    assert "lost RTDE link" in arm.fault()
    assert wait_until(lambda: "lost RTDE link" in (safe.supervise() or ""), 0.5)
    # the controller's own RTDE watchdog stops the arm nobody can reach any more
    assert wait_until(lambda: ur.state()["velocity"] == [0.0] * 6, 1.0), ur.state()


def test_loads_handed_to_the_emulator_reach_the_force_readback_and_the_force_limit(arm, ur, safe):
    ur.call("external_wrench 0 0 -30")
    assert wait_until(lambda: np.allclose(arm.tcp_wrench()[:3], [0.0, 0.0, -30.0]), 1.0)
    assert safe.supervise() is None
    ur.call("external_wrench 0 0 -200")  # beyond the safety layer's 150 N
    assert wait_until(lambda: "force limit" in (safe.supervise() or ""), 1.0)
    assert wait_until(lambda: ur.state()["velocity"] == [0.0] * 6, 1.0)


def test_emergency_stop_is_a_fault(arm, ur):
    ur.call("estop")
    assert wait_until(lambda: arm.fault() is not None, 1.0)
    assert "emergency stop" in arm.fault()


def test_unreachable_controller_gives_an_actionable_error(clock):
    host = next_host()  # nothing listens there
    with pytest.raises(DriverFault, match=rf"cannot reach UR dashboard at {host}:29999.*refused"):
        UrArm(UrConfig(host), clock)
