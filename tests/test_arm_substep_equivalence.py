"""The simulated arm's sub-step (`KinematicArm._advance`) is written out for speed (the motion helpers
inlined, no ramp of a rotation nobody asks for, 3x3 products by `dot`): driven beside its plain form,
written here with `approach_speed` and `ramp` as `drivers.sim.devices.arm_motion` states them and
the rotations multiplied with `@`, through the same moves that turn, twists, stops and command
latencies, it must give the same floats every tick."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivers.clock import SimClock
from drivers.sim.devices.arm import ZERO, KinematicArm, _close, _stopping
from drivers.sim.devices.arm_motion import CONTROL_PERIOD, IDEAL, ArmMotion, approach_speed, ramp
from drivers.sim.transforms import matrix_to_rotvec, rotvec_to_matrix


class PlainArm(KinematicArm):
    """The arm with its sub-step in the plain form: each speed from `approach_speed`, each velocity
    change through `ramp`, the position and the turn updated by list comprehensions."""

    def _advance(self, h: float, p: list[float], turn: list[float]) -> float:
        motion = self.motion
        accel, ang_accel = (motion.stop_deceleration,) * 2 if self._stopping else (
            motion.acceleration, motion.angular_acceleration)
        axis, angle, dist = ZERO, 0.0, 0.0
        if self._target is not None:
            target = self._goal
            left = [target[0] - p[0], target[1] - p[1], target[2] - p[2]]
            dist = math.hypot(*left)
            speed = approach_speed(dist, self._target_speed, accel, h)
            v_goal = [x / dist * speed for x in left] if dist > 1e-12 else list(ZERO)
            axis, angle = (ZERO, 0.0) if self._turned else self._rotation_left(p, target, turn)
            rate = approach_speed(angle, self.max_angular_speed, ang_accel, h)
            w_goal = [a * rate for a in axis]
            steady = (speed == self._target_speed and _close(v_goal, self._v) and not angle and not any(self._w)
                      and self._target_speed * h + _stopping(speed, accel) < dist)
        elif self._stopping:
            v_goal, w_goal, steady = list(ZERO), list(ZERO), False
        else:
            vx, vy, vz = self._twist[:3]
            n = math.hypot(vx, vy, vz)
            k = self.max_speed / n if n > self.max_speed else 1.0
            v_goal, w_goal = [vx * k, vy * k, vz * k], list(self._twist[3:])
            steady = _close(v_goal, self._v) and _close(w_goal, self._w)
        if not (steady or self._ideal):
            h = min(h, CONTROL_PERIOD)
        v0 = self._v
        self._v = ramp(v0, v_goal, accel * h)
        self._w = ramp(self._w, w_goal, ang_accel * h)
        step = [(a + b) * 0.5 * h for a, b in zip(v0, self._v)] if accel > 0.0 else [b * h for b in self._v]
        if self._target is not None and dist <= max(math.hypot(*step), 1e-9):
            p[:3], self._v = self._goal[:3], list(ZERO)
        else:
            p[:3] = [x + s for x, s in zip(p[:3], step)]
        rotated = [w * h for w in self._w]
        if self._target is not None and not self._turned and angle <= math.hypot(*rotated):
            rotated, self._w, self._turned = [a * angle for a in axis], list(ZERO), True
        for i in range(3):
            turn[i] += rotated[i]
        if self._stopping and not any(self._v) and not any(self._w):
            self._stopping = False
        return h

    def _rotation_left(self, pose: list[float], target: list[float], turn: list[float]) -> tuple[list[float], float]:
        if max(abs(target[3] - pose[3]), abs(target[4] - pose[4]), abs(target[5] - pose[5])) <= 1e-9:
            return list(ZERO), 0.0
        if self._start_rotation is None:
            self._start_rotation = rotvec_to_matrix(pose[3:6])
        cur = rotvec_to_matrix(turn) @ self._start_rotation if any(turn) else self._start_rotation
        err = matrix_to_rotvec(self._goal_rotation @ cur.T).tolist()
        angle = math.hypot(*err)
        if angle < 1e-9:
            return list(ZERO), 0.0
        return [e / angle for e in err], angle


MOTIONS = {"ur": ArmMotion(), "kinematic": IDEAL, "no latency": ArmMotion(latency=0.0),
           "fast stops": ArmMotion(acceleration=1.2, angular_acceleration=0.25, stop_deceleration=4.0, latency=0.033)}


@pytest.mark.parametrize("name", MOTIONS)
def test_the_arm_moves_as_its_plain_sub_step_moves_it_bit_for_bit(name: str):
    clock = SimClock(1.0 / 30.0)
    home = np.array([0.1, -0.2, 0.5, np.pi, 0.0, 0.0])
    arms = [KinematicArm(clock, home, motion=MOTIONS[name]), PlainArm(clock, home, motion=MOTIONS[name])]
    rng = np.random.default_rng(7)
    moved = turned = 0
    for tick in range(1200):
        phase = tick % 120
        if phase == 0:  # a move that turns, near a half turn where rounding matters most
            goal = arms[0].pose() + np.r_[rng.normal(0.0, 0.08, 3), rng.normal(0.0, 0.3, 3)]
            goal[3:] *= min(1.0, np.pi / np.linalg.norm(goal[3:]))
            commands = [("move_linear", goal, float(rng.uniform(0.02, 0.3)))]
        elif phase == 50:  # a move without turning
            commands = [("move_linear", np.r_[arms[0].pose()[:3] + rng.normal(0.0, 0.05, 3), arms[0].pose()[3:]], 0.1)]
        elif phase == 80:  # twists, the second one a turn too, then a zero twist and a stop
            commands = [("speed_linear", np.r_[rng.normal(0.0, 0.05, 3), 0.0, 0.0, 0.0])]
        elif phase == 90:
            commands = [("speed_linear", np.r_[rng.normal(0.0, 0.4, 3), 0.0, 0.0, 0.3])]
        elif phase == 100:
            commands = [("speed_linear", np.zeros(6))]
        elif phase == 110:
            commands = [("stop",)]
        else:
            commands = []
        for arm in arms:
            for command, *args in commands:
                getattr(arm, command)(*args)
            arm.step(clock.period)
        assert arms[0].pose().tobytes() == arms[1].pose().tobytes()
        assert arms[0].tcp_speed().tobytes() == arms[1].tcp_speed().tobytes()
        assert arms[0].is_moving() == arms[1].is_moving()
        moved += any(arms[0].tcp_speed()[:3])
        turned += any(arms[0].tcp_speed()[3:])
        clock.advance()
    assert moved > 300 and turned > 50  # the arm did move and turn: the comparison was not of two arms at rest


def test_dot_gives_the_bits_of_matmul_on_rotations():
    """The arm's step turns its pose by `dot` where it used `@` (the same BLAS product for 3x3 float
    matrices, at half the cost of a call): the same bits, also with a transposed operand."""
    rng = np.random.default_rng(3)
    for i in range(3000):
        a, b = rotvec_to_matrix(rng.normal(0.0, 1.5, 3)), rotvec_to_matrix(rng.normal(0.0, 1.5, 3))
        if i % 3 == 0:
            a = rng.normal(0.0, 10.0, (3, 3))
        assert a.dot(b).tobytes() == (a @ b).tobytes()
        assert a.dot(b.T).tobytes() == (a @ b.T).tobytes()
