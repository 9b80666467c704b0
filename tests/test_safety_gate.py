"""The finiteness and sanity gate at the safety boundary, fuzzed with hypothesis: no non-finite,
non-positive, over-turned or misshapen command reaches a driver, every one latches a fault, every
finite in-range command passes (clamped and capped as configured), and nothing a driver raises or
reads back escapes the safety layer. `-s` prints the table of refused non-finite commands."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from assembly.testing import mock_cell
from drivers.cell_builders import load_cell
from drivers.clock import SimClock
from drivers.guard import ROTVEC_TOLERANCE
from drivers.protocols import DriverFault
from drivers.safe_gripper import SafeGripper
from drivers.safety import SafeArm, SafetyLimits
from drivers.sim.devices.arm import KinematicArm
from drivers.sim.devices.gripper import SimGripper

FUZZ = settings(max_examples=300, deadline=None, derandomize=True, database=None)
HOME = np.array([0.0, 0.0, 0.5, np.pi, 0.0, 0.0])
LIMITS = SafetyLimits(workspace_min=[-0.5, -0.5, 0.1], workspace_max=[0.5, 0.5, 0.8], max_speed=0.2,
                      max_angular_speed=0.8)
NON_FINITE = (math.nan, math.inf, -math.inf)
RAISED = (DriverFault("link lost"), ValueError("The value is considered NaN"), RuntimeError("boom"),
          OSError("socket closed"), ZeroDivisionError("division by zero"), KeyError("pose"))


class SpyArm(KinematicArm):
    """The kinematic arm, recording what reaches it; `readings` overrides what it reads back."""

    def __init__(self, clock):
        super().__init__(clock, HOME)
        self.received: list[tuple] = []
        self.stops = 0

    def move_linear(self, pose, speed):
        self.received.append(("move_linear", np.array(pose), speed))
        super().move_linear(pose, speed)

    def speed_linear(self, twist):
        self.received.append(("speed_linear", np.array(twist)))
        super().speed_linear(twist)

    def stop(self):
        self.stops += 1
        super().stop()


class SpyGripper(SimGripper):
    """The simulated gripper, recording what reaches it."""

    def __init__(self):
        super().__init__(max_width=0.085, max_speed=0.15)
        self.received: list[tuple] = []
        self.stops = 0

    def move(self, width, speed=0.05, force=20.0):
        self.received.append((width, speed, force))
        super().move(width, speed, force)

    def stop(self):
        self.stops += 1
        super().stop()


def safe_arm(limits: SafetyLimits = LIMITS) -> tuple[SafeArm, SpyArm]:
    clock = SimClock(0.01)
    arm = SpyArm(clock)
    return SafeArm(arm, limits, clock), arm


def safe_gripper() -> tuple[SafeGripper, SpyGripper]:
    gripper = SpyGripper()
    return SafeGripper(gripper, max_force=100.0), gripper


# --- strategies -------------------------------------------------------------------------------
coordinate = st.floats(-2.0, 2.0)
angle = st.floats(0.0, math.pi)
axis = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(lambda a: np.linalg.norm(a) > 1e-3)


@st.composite
def rotation_vectors(draw, angles=angle) -> np.ndarray:
    a = np.array(draw(axis))
    return a / np.linalg.norm(a) * draw(angles)


@st.composite
def poses(draw) -> np.ndarray:
    return np.r_[draw(coordinate), draw(coordinate), draw(coordinate), draw(rotation_vectors())]


@st.composite
def with_non_finite(draw, vectors) -> np.ndarray:
    """A vector from `vectors` with one or more entries made NaN or infinite."""
    v = np.array(draw(vectors), dtype=float)
    for i in draw(st.sets(st.integers(0, len(v) - 1), min_size=1)):
        v[i] = draw(st.sampled_from(NON_FINITE))
    return v


speeds = st.floats(1e-6, 1e3)
bad_speeds = st.one_of(st.sampled_from(NON_FINITE), st.floats(max_value=0.0, allow_nan=False))
twists = st.lists(st.floats(-1e6, 1e6), min_size=6, max_size=6).map(np.array)
wrong_shapes = st.one_of(st.lists(st.floats(-1, 1), max_size=12).filter(lambda v: len(v) != 6),
                         st.just([[0.0] * 6]), st.just("0 0 0.5 3.14 0 0"), st.just(None), st.just({"x": 1.0}))
over_turned = st.builds(lambda p, r: np.r_[p[:3], r], poses(),
                        rotation_vectors(st.floats(math.pi + 2 * ROTVEC_TOLERANCE, 100.0)))


def assert_refused(safe, inner, command: str) -> None:
    assert inner.received == [], f"{command} reached the driver: {inner.received}"
    assert safe.fault() is not None and f"{command} refused" in safe.fault()
    assert inner.stops >= 1  # the device was stopped when the fault latched


# --- the arm --------------------------------------------------------------------------------
@FUZZ
@given(pose=poses(), speed=speeds)
def test_a_finite_in_range_move_passes_clamped_into_the_box(pose, speed):
    safe, arm = safe_arm()
    safe.move_linear(pose, speed)
    assert safe.fault() is None
    [(name, target, sent_speed)] = arm.received
    assert name == "move_linear"
    assert np.array_equal(target[:3], np.clip(pose[:3], LIMITS.workspace_min, LIMITS.workspace_max))
    assert np.array_equal(target[3:], pose[3:])
    assert sent_speed == min(speed, LIMITS.max_speed)


@FUZZ
@given(pose=with_non_finite(poses()), speed=speeds)
def test_a_move_to_a_non_finite_pose_never_reaches_the_arm(pose, speed):
    safe, arm = safe_arm()
    safe.move_linear(pose, speed)
    assert_refused(safe, arm, "move_linear")
    assert "is not finite" in safe.fault()


@FUZZ
@given(pose=poses(), speed=bad_speeds)
def test_a_move_at_a_non_finite_or_non_positive_speed_never_reaches_the_arm(pose, speed):
    safe, arm = safe_arm()
    safe.move_linear(pose, speed)
    assert_refused(safe, arm, "move_linear")


@FUZZ
@given(pose=over_turned, speed=speeds)
def test_a_rotation_vector_beyond_pi_never_reaches_the_arm(pose, speed):
    safe, arm = safe_arm()
    safe.move_linear(pose, speed)
    assert_refused(safe, arm, "move_linear")
    assert "beyond pi" in safe.fault()


@FUZZ
@given(pose=wrong_shapes)
def test_a_misshapen_pose_or_twist_never_reaches_the_arm(pose):
    safe, arm = safe_arm()
    safe.move_linear(pose, 0.1)
    assert_refused(safe, arm, "move_linear")
    safe, arm = safe_arm()
    safe.speed_linear(pose)
    assert_refused(safe, arm, "speed_linear")


@FUZZ
@given(twist=twists)
def test_a_finite_twist_passes_with_its_linear_speed_capped_or_is_refused_for_turning_too_fast(twist):
    safe, arm = safe_arm()
    safe.speed_linear(twist)
    if np.linalg.norm(twist[3:]) > LIMITS.max_angular_speed:
        assert_refused(safe, arm, "speed_linear")
        return
    assert safe.fault() is None
    [(_, sent)] = arm.received
    assert np.allclose(sent[3:], twist[3:])
    asked, got = twist[:3], sent[:3]
    assert np.linalg.norm(got) <= LIMITS.max_speed * (1 + 1e-9)
    if np.linalg.norm(asked) <= LIMITS.max_speed:
        assert np.allclose(got, asked)
    else:  # scaled down, same direction
        assert np.allclose(got / np.linalg.norm(got), asked / np.linalg.norm(asked))


@FUZZ
@given(twist=with_non_finite(twists))
def test_a_non_finite_twist_never_reaches_the_arm(twist):
    safe, arm = safe_arm()
    safe.speed_linear(twist)
    assert_refused(safe, arm, "speed_linear")


@FUZZ
@given(reading=st.sampled_from(["tcp_wrench", "pose"]), values=with_non_finite(twists))
def test_a_non_finite_force_or_pose_reading_trips_the_stop(reading, values):
    safe, arm = safe_arm()
    safe.speed_linear(np.array([0.0, 0.0, -0.01, 0, 0, 0]))
    setattr(arm, reading, lambda: values.copy())
    fault = safe.supervise()
    assert fault is not None and f"bad reading: {reading}" in fault and "not finite" in fault
    assert not arm.is_moving()


@FUZZ
@given(command=st.sampled_from(["move_linear", "speed_linear", "pose", "tcp_wrench", "tcp_speed",
                                "state_stamp", "is_moving", "fault", "stop", "kick_watchdog"]),
       exc=st.sampled_from(RAISED))
def test_whatever_a_driver_raises_latches_a_fault_and_never_escapes(command, exc):
    clock = SimClock(0.01)
    arm = SpyArm(clock)

    def raising(*_):
        raise exc

    setattr(arm, command, raising)
    safe = SafeArm(arm, LIMITS, clock)  # an arm with kick_watchdog is kicked too
    safe.move_linear(HOME, 0.1)
    safe.speed_linear(np.zeros(6))
    safe.pose(), safe.tcp_speed(), safe.tcp_wrench(), safe.state_stamp(), safe.is_moving()
    safe.kick()
    safe.stop()
    fault = safe.supervise()
    assert fault is not None and command in fault and str(exc.args[0]) in fault


def test_the_issue_s_commands_are_refused_or_capped():
    safe, arm = safe_arm()
    safe.move_linear([math.nan, 0, 0.5, 3.14, 0, 0], 0.1)
    assert safe.fault() == "move_linear refused: pose [nan, 0.0, 0.5, 3.14, 0.0, 0.0] is not finite"
    safe, arm = safe_arm()
    safe.move_linear([0.4, 0, 0.5, 3.14, 0, 0], -0.1)
    assert safe.fault() == "move_linear refused: speed -0.1 must be positive"
    safe, arm = safe_arm()
    safe.speed_linear([math.inf, 0, 0, 0, 0, 0])
    assert safe.fault() == "speed_linear refused: twist [inf, 0.0, 0.0, 0.0, 0.0, 0.0] is not finite"
    safe, arm = safe_arm()
    safe.speed_linear([0, 0, 0, 0, 0, 1e6])
    assert arm.received == [] and "angular speed 1e+06 rad/s is over" in safe.fault()


def test_every_latched_cause_is_reported_and_commands_stay_refused():
    safe, arm = safe_arm()
    arm.fault_text = "protective stop"
    safe.trip("gripper fault: overcurrent")
    assert safe.fault() == "gripper fault: overcurrent; driver fault: protective stop"
    safe.move_linear(HOME, 0.1)
    assert arm.received == []
    arm.fault_text = None
    safe.reset()
    assert safe.fault() is None
    safe.move_linear(HOME, 0.1)
    assert len(arm.received) == 1


@pytest.mark.parametrize("field, value", [
    ("max_force", math.nan), ("stale_after", math.nan), ("watchdog_timeout", math.inf), ("max_speed", -0.1),
    ("max_angular_speed", 0.0), ("max_force", True), ("max_speed", "fast"),
    ("workspace_min", [math.nan, -1.0, 0.0]), ("workspace_max", [1.0, math.inf, 1.0]), ("workspace_max", [1.0, 1.0]),
    ("workspace_min", "low"),
])
def test_limits_refuse_non_finite_and_non_positive_values(field, value):
    with pytest.raises(ValueError, match=field):
        SafetyLimits(**{field: value})


# --- the gripper ---------------------------------------------------------------------------------
widths = st.floats(0.0, 0.085)
grip_speeds = st.floats(1e-6, 10.0)
forces = st.floats(0.0, 100.0)


@FUZZ
@given(width=widths, speed=grip_speeds, force=forces)
def test_a_finite_in_range_grip_passes_with_its_speed_capped(width, speed, force):
    safe, gripper = safe_gripper()
    safe.move(width, speed, force)
    assert safe.fault() is None
    assert gripper.received == [(width, min(speed, gripper.max_speed), force)]


@FUZZ
@given(args=st.tuples(widths, grip_speeds, forces), which=st.sets(st.integers(0, 2), min_size=1),
       bad=st.sampled_from(NON_FINITE))
def test_a_non_finite_grip_never_reaches_the_gripper(args, which, bad):
    safe, gripper = safe_gripper()
    safe.move(*[bad if i in which else a for i, a in enumerate(args)])
    assert_refused(safe, gripper, "gripper move")


@FUZZ
@given(args=st.one_of(
    st.tuples(st.one_of(st.floats(max_value=-1e-5), st.floats(min_value=0.0851)), grip_speeds, forces),
    st.tuples(widths, st.floats(max_value=0.0), forces),
    st.tuples(widths, grip_speeds, st.one_of(st.floats(max_value=-1e-9), st.floats(min_value=100.001)))))
def test_a_grip_out_of_range_never_reaches_the_gripper(args):
    safe, gripper = safe_gripper()
    safe.move(*args)
    assert_refused(safe, gripper, "gripper move")


@FUZZ
@given(command=st.sampled_from(["move", "width", "is_moving", "object_detected", "fault", "stop"]),
       exc=st.sampled_from(RAISED))
def test_whatever_a_gripper_driver_raises_latches_a_fault_and_stop_stays_safe(command, exc):
    safe, gripper = safe_gripper()

    def raising(*_):
        raise exc

    setattr(gripper, command, raising)
    safe.move(0.04, 0.05, 20.0)
    safe.width(), safe.is_moving(), safe.object_detected()
    safe.stop()
    fault = safe.fault()
    assert fault is not None and command in fault and str(exc.args[0]) in fault


def test_the_gripper_driver_s_own_fault_latches_and_stops_the_fingers():
    safe, gripper = safe_gripper()
    safe.move(0.0, 0.05, 20.0)
    gripper.fault_text = "overcurrent triggered: reactivate"
    assert safe.fault() == "driver fault: overcurrent triggered: reactivate"
    assert gripper.stops == 1 and not gripper.is_moving()
    gripper.fault_text = None  # gone at the driver, still latched here
    assert "overcurrent" in safe.fault()
    safe.move(0.085, 0.05, 20.0)
    assert len(gripper.received) == 1
    safe.trip("arm fault: force limit")
    assert safe.fault() == "driver fault: overcurrent triggered: reactivate; arm fault: force limit"


def test_every_cell_builder_puts_the_gripper_behind_the_safety_layer():
    assert isinstance(mock_cell().gripper, SafeGripper)
    assert isinstance(load_cell("sim", 30.0, "hold").gripper, SafeGripper)


# --- the closing note's table --------------------------------------------------------------------
def _arm_trials():
    """(kind, command) for every non-finite (or non-positive, over-turned) arm command tried."""
    for i in range(6):
        for bad in NON_FINITE:
            pose = HOME.copy()
            pose[i] = bad
            yield "move_linear pose", lambda s, p=pose: s.move_linear(p, 0.1)
            twist = np.zeros(6)
            twist[i] = bad
            yield "speed_linear twist", lambda s, t=twist: s.speed_linear(t)
    for bad in (*NON_FINITE, 0.0, -0.1):
        yield "move_linear speed", lambda s, v=bad: s.move_linear(HOME, v)
    for norm in (math.pi + 0.01, 2 * math.pi, 1e6):
        yield "move_linear rotation > pi", lambda s, r=norm: s.move_linear(np.r_[HOME[:3], r, 0, 0], 0.1)


def _gripper_trials():
    for i, kind in enumerate(("width", "speed", "force")):
        for bad in NON_FINITE:
            args = [0.04, 0.05, 20.0]
            args[i] = bad
            yield f"gripper move {kind}", lambda s, a=tuple(args): s.move(*a)
    yield "gripper move speed", lambda s: s.move(0.04, 0.0, 20.0)
    yield "gripper move speed", lambda s: s.move(0.04, -0.05, 20.0)


def test_every_non_finite_command_is_refused_table():
    rows: dict[str, list[int]] = {}
    for trials, make in ((_arm_trials(), safe_arm), (_gripper_trials(), safe_gripper)):
        for kind, command in trials:
            safe, inner = make()
            command(safe)
            refused = not inner.received and safe.fault() is not None
            row = rows.setdefault(kind, [0, 0])
            row[0] += 1
            row[1] += refused
    print("\n| command | tried | refused |\n|---|---:|---:|")
    for kind, (tried, refused) in rows.items():
        print(f"| {kind} | {tried} | {refused} ({100 * refused / tried:.0f} %) |")
    assert all(tried == refused for tried, refused in rows.values()), rows
