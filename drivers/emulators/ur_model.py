"""The emulated UR controller: TCP motion, a contact plane, safety stops, the RTDE watchdog, and
the command-register protocol of ur_rtde's control script (ready 1 / done 2 on output int 0).

One `step(dt)` is one controller cycle (2 ms e-Series, 8 ms CB3). Kinematics only: the TCP moves
as commanded within acceleration limits; joints are not modelled (actual_q is constant).
Emulated time may run `time_scale` times faster than the wall clock (long trees in tests): motion,
the RTDE timestamp, speedL's time limit and the RTDE watchdog all count emulated seconds.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

# Command ids written to input_int_register_0 by ur_rtde (scripts/rtde_control.script).
MOVEL, FORCE_MODE, FORCE_MODE_STOP, ZERO_FT, SPEEDJ, SPEEDL, SERVOJ = 3, 6, 7, 8, 9, 10, 11
SPEED_STOP, SERVO_STOP, SERVOL, PROTECTIVE_STOP, STOPL, STOPJ = 15, 16, 24, 31, 33, 34
SET_WATCHDOG, IS_POSE_WITHIN_SAFETY_LIMITS, IS_STEADY, MOVE_UNTIL_CONTACT, STOP_SCRIPT = 35, 36, 47, 51, 255
# Commands the 1.6.5 script acknowledges with "ready" at once instead of "done" (streaming, queries).
REALTIME = {FORCE_MODE, SPEEDJ, SPEEDL, SERVOJ, SERVOL, 25, 26, 27, 38, 58, 66, 67, 68, 69, 70, 71}
# The input double registers each command reads: a setpoint, speed, acceleration, time or rate.
SETPOINT_REGISTERS = {MOVEL: range(8), SPEEDL: range(8), SERVOL: range(11), MOVE_UNTIL_CONTACT: (*range(6), 12),
                      STOPL: (0,), STOPJ: (0,), SET_WATCHDOG: (0,)}
READY, DONE = 1, 2

# robot/safety status encodings (RTDE guide)
RUNTIME_STOPPED, RUNTIME_PLAYING = 1, 2
ROBOT_MODE_POWER_OFF, ROBOT_MODE_RUNNING = 3, 7
SAFETY_NORMAL, SAFETY_PROTECTIVE_STOP, SAFETY_ROBOT_EMERGENCY_STOP = 1, 3, 7
BIT_NORMAL, BIT_PROTECTIVE_STOPPED, BIT_ROBOT_ESTOP, BIT_ESTOP = 0, 2, 6, 7

HOME_POSE = (0.0, -0.4, 0.4, np.pi, 0.0, 0.0)
HOME_Q = (0.0, -1.57, 1.57, -1.57, -1.57, 0.0)


@dataclass
class ContactPlane:
    """A horizontal surface at height `z`: the TCP pushing below it feels a spring force."""

    z: float | None = None
    stiffness: float = 20000.0  # N/m
    protective_force: float = 300.0  # N; more than this trips a protective stop, like the controller's limit


class UrModel:
    """Controller state machine; thread-safe (RTDE readers write inputs, the loop steps)."""

    def __init__(self, major_version: int = 5, plane: ContactPlane | None = None,
                 time_scale: float = 1.0):
        if time_scale <= 0:
            raise ValueError(f"time_scale must be positive, got {time_scale}")
        self.lock = threading.RLock()
        self.major_version = major_version
        self.time_scale = time_scale
        self.period = 0.008 if major_version <= 3 else 0.002
        self.plane = plane or ContactPlane()
        self.t0 = time.monotonic()
        self.pose = np.array(HOME_POSE, dtype=float)
        self.velocity = np.zeros(6)
        self.force = np.zeros(6)
        self.external_wrench = np.zeros(6)  # loads of a world outside the emulator (its back door)
        self.inputs: dict[str, object] = {}
        self.out_int = [0] * 48
        self.out_double = [0.0] * 48
        self.program_running = False
        self.protective_stopped = False
        self.estopped = False
        self.events: list[tuple[float, str]] = []  # (monotonic time, what happened)
        self.servo_updates: list[float] = []  # monotonic stamps of servo commands received
        self._executing = False
        self._blocking: str | None = None  # a non-realtime command still running
        self._mode = "idle"  # idle | move | speed | servo | stop | contact
        self._target: np.ndarray | None = None
        self._start: np.ndarray | None = None
        self._twist = np.zeros(6)
        self._accel = 1.2
        self._speed = 0.25
        self._speed_deadline: float | None = None
        self._lookahead = 0.1
        self._path_s = 0.0
        self._path_v = 0.0
        self._path_len = 0.0
        self._async_move = False
        self._async_writes = 0
        self._async_op_id = 0
        self._watchdog_hz = 0.0
        self._last_cmd_write = 0.0

    def now(self) -> float:
        """Emulated seconds since start-up (the RTDE timestamp)."""
        return (time.monotonic() - self.t0) * self.time_scale

    # --- inputs from RTDE clients -------------------------------------------------------------
    def write_inputs(self, values: dict[str, object]) -> None:
        with self.lock:
            self.inputs.update(values)
            if "input_int_register_0" in values:
                self._last_cmd_write = self.now()
                if values["input_int_register_0"] == SERVOL:
                    self.servo_updates.append(time.monotonic())

    def _in_int(self, i: int) -> int:
        return int(self.inputs.get(f"input_int_register_{i}", 0))

    def _in_double(self, i: int) -> float:
        return float(self.inputs.get(f"input_double_register_{i}", 0.0))

    def _in_vec(self, first: int) -> np.ndarray:
        return np.array([self._in_double(first + k) for k in range(6)])

    # --- program lifecycle ----------------------------------------------------------------------
    def start_program(self) -> None:
        """A script arrived on port 30003: it runs unless a safety stop is active."""
        with self.lock:
            if self.protective_stopped or self.estopped:
                self._event("script rejected: robot is safety-stopped")
                return
            self.program_running = True
            self._executing = False
            self._blocking = None
            self._watchdog_hz = 0.0
            self._write_async_progress(-1)
            self.out_int[0] = READY
            self._event("control script started")

    def stop_program(self, why: str) -> None:
        with self.lock:
            if self.program_running:
                self._event(f"program stopped: {why}")
            self.program_running = False
            self._blocking = None
            self.out_int[0] = 0
            self._begin_stop(10.0)

    def protective_stop(self, why: str) -> None:
        with self.lock:
            self.protective_stopped = True
            self._halt()
            self.stop_program(f"protective stop ({why})")
            self._event(f"protective stop: {why}")

    def emergency_stop(self) -> None:
        with self.lock:
            self.estopped = True
            self._halt()
            self.stop_program("emergency stop")
            self._event("emergency stop")

    def release_emergency_stop(self) -> None:
        with self.lock:
            self.estopped = False
            self._event("emergency stop released")

    def unlock_protective_stop(self) -> bool:
        with self.lock:
            if not self.protective_stopped:
                return False
            self.protective_stopped = False
            self._event("protective stop unlocked")
            return True

    def _halt(self) -> None:
        self.velocity[:] = 0.0
        self._mode = "idle"
        self._finish_async()

    def _event(self, text: str) -> None:
        self.events.append((time.monotonic(), text))

    # --- one controller cycle ------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """One controller cycle of `dt` emulated seconds."""
        with self.lock:
            now = self.now()
            if (self.program_running and self._watchdog_hz > 0
                    and now - self._last_cmd_write > 1.0 / self._watchdog_hz):
                self.stop_program(f"RTDE watchdog: input_int_register_0 not updated for "
                                  f"{now - self._last_cmd_write:.3f} s")
            if self.program_running:
                self._script_cycle()
            self._integrate(dt)
            self._update_force()

    def _script_cycle(self) -> None:
        if self._blocking is not None:
            return  # process_cmd() has not returned yet
        cmd = self._in_int(0)
        if cmd in REALTIME:
            self._process(cmd)
            self.out_int[0] = READY
        elif cmd == 0:
            self._executing = False
            self.out_int[0] = READY
        elif not self._executing:
            self._executing = True
            self._process(cmd)
            if self._blocking is None and self.program_running:
                self.out_int[0] = DONE

    def _process(self, cmd: int) -> None:
        bad = [i for i in SETPOINT_REGISTERS.get(cmd, ()) if not np.isfinite(self._in_double(i))]
        if bad:
            # As the controller does with an invalid setpoint: refuse it and stop the arm safely.
            self.protective_stop(f"invalid setpoint: command {cmd} with non-finite input_double_register "
                                 f"{', '.join(map(str, bad))}")
            return
        if cmd == MOVEL:
            self._begin_move(self._in_vec(0), self._in_double(6), self._in_double(7),
                             asynchronous=self._in_int(1) == 1)
        elif cmd in (SPEEDL, MOVE_UNTIL_CONTACT):
            self._twist = self._in_vec(0)
            if cmd == SPEEDL:
                self._accel = self._in_double(6) or 0.25
                t = self._in_double(7)
                self._speed_deadline = self.now() + t if t > 0 else None
                self._mode = "speed"
            else:
                self._accel = self._in_double(12) or 1.2
                self._speed_deadline = None
                self._mode = "contact"
                self._blocking = "move_until_contact"
        elif cmd == SERVOL:
            self._target = self._in_vec(0)
            self._lookahead = min(max(self._in_double(9), 0.03), 0.2)
            self._mode = "servo"
        elif cmd in (STOPL, STOPJ, SPEED_STOP, SERVO_STOP, FORCE_MODE_STOP):
            self._finish_async()
            self._begin_stop(self._in_double(0) if cmd in (STOPL, STOPJ) else 10.0)
            self._blocking = "stop"
        elif cmd == SET_WATCHDOG:
            self._watchdog_hz = self._in_double(0)
            self._last_cmd_write = self.now()
            self._event(f"RTDE watchdog set to {self._watchdog_hz:g} Hz")
        elif cmd == PROTECTIVE_STOP:
            self.protective_stop("triggered by the client")
        elif cmd == IS_POSE_WITHIN_SAFETY_LIMITS:
            self.out_int[1] = 1
        elif cmd == IS_STEADY:
            self.out_int[1] = int(not np.any(self.velocity))
        elif cmd == STOP_SCRIPT:
            self.stop_program("stopScript")
        # zeroFtSensor, forceMode and the rest are accepted and have no effect here.

    # --- motion ------------------------------------------------------------------------------------
    def _begin_move(self, target: np.ndarray, speed: float, accel: float, asynchronous: bool) -> None:
        self._finish_async()
        self._start, self._target = self.pose.copy(), target
        self._speed, self._accel = max(speed, 1e-4), max(accel, 1e-3)
        turn = Rotation.from_rotvec(target[3:]) * Rotation.from_rotvec(self._start[3:]).inv()
        # path length: translation, or 10 cm per radian for a pure reorientation
        self._path_len = max(float(np.linalg.norm(target[:3] - self._start[:3])),
                             float(np.linalg.norm(turn.as_rotvec())) * 0.1, 1e-9)
        self._path_s, self._path_v = 0.0, 0.0
        self._mode = "move"
        self._async_move = asynchronous
        if asynchronous:
            self._write_async_progress(0)
        else:
            self._blocking = "movel"

    def _begin_stop(self, decel: float) -> None:
        self._accel = max(decel, 0.1)
        self._mode = "stop" if np.any(self.velocity) else "idle"

    def _finish_async(self) -> None:
        if self._async_move:
            self._async_move = False
            self._write_async_progress(-1)

    def _write_async_progress(self, value: int) -> None:
        """Output int 2 as the 1.6.5 script packs it: operation id in bits 24-30, a write counter
        in bits 16-22, bit 15 set while an operation runs, its progress in bits 0-14."""
        self._async_writes = (self._async_writes + 1) % 128
        if value == 0:
            self._async_op_id = (self._async_op_id + 1) % 128
        reg = (self._async_op_id << 24) | (self._async_writes << 16)
        if value >= 0:
            reg |= 0x8000 | min(value, 0x7FFF)
        self.out_int[2] = reg

    def _complete_blocking(self) -> None:
        if self._blocking is not None:
            self._blocking = None
            if self.program_running:
                self.out_int[0] = DONE

    def _integrate(self, dt: float) -> None:
        before = self.pose.copy()
        velocity_driven = self._mode in ("speed", "contact", "stop")
        if self._mode == "move":
            self._integrate_move(dt)
        elif self._mode in ("speed", "contact"):
            if self._speed_deadline is not None and self.now() >= self._speed_deadline:
                self._twist = np.zeros(6)
            self._ramp_velocity(self._twist, dt)
            self._apply_velocity(dt)
            if self._mode == "contact" and self._in_contact():
                self.pose[2] = self.plane.z  # ur_rtde retracts to the point of first contact
                self.velocity[:] = 0.0
                self._mode = "idle"
                self._event("moveUntilContact: contact")
                self._complete_blocking()
        elif self._mode == "servo":
            alpha = min(1.0, dt / self._lookahead)
            self.pose[:3] += (self._target[:3] - self.pose[:3]) * alpha
            self.pose[3:] = _rot_towards(self.pose[3:], self._target[3:], alpha)
        elif self._mode == "stop":
            self._ramp_velocity(np.zeros(6), dt)
            self._apply_velocity(dt)
            if not np.any(self.velocity):
                self._mode = "idle"
        if self._mode in ("idle",) and self._blocking == "stop":
            self._complete_blocking()
        if not velocity_driven:
            self.velocity[:3] = (self.pose[:3] - before[:3]) / dt  # angular rate not reported here
            self.velocity[3:] = 0.0

    def _integrate_move(self, dt: float) -> None:
        delta = self._target[:3] - self._start[:3]
        length = self._path_len
        remaining = length - self._path_s
        self._path_v = min(self._path_v + self._accel * dt, self._speed,
                           float(np.sqrt(2.0 * self._accel * max(remaining, 0.0))) + self._accel * dt)
        self._path_s = min(self._path_s + self._path_v * dt, length)
        frac = self._path_s / length
        self.pose[:3] = self._start[:3] + delta * frac
        self.pose[3:] = _rot_towards(self._start[3:], self._target[3:], frac)
        if self._path_s >= length - 1e-9:
            self.pose = self._target.copy()
            self._mode = "idle"
            self._finish_async()
            self._complete_blocking()

    def _ramp_velocity(self, goal: np.ndarray, dt: float) -> None:
        dv = goal - self.velocity
        n = float(np.linalg.norm(dv[:3]))
        step = self._accel * dt
        if n > step:
            dv *= step / n
        self.velocity = self.velocity + dv
        if not np.any(goal) and float(np.linalg.norm(self.velocity[:3])) < 1e-6:
            self.velocity[:] = 0.0

    def _apply_velocity(self, dt: float) -> None:
        self.pose[:3] += self.velocity[:3] * dt
        if np.any(self.velocity[3:]):
            rot = Rotation.from_rotvec(self.velocity[3:] * dt) * Rotation.from_rotvec(self.pose[3:])
            self.pose[3:] = rot.as_rotvec()

    def _in_contact(self) -> bool:
        return self.plane.z is not None and self.pose[2] <= self.plane.z

    def _update_force(self) -> None:
        self.force[:] = self.external_wrench
        if self.plane.z is not None and self.pose[2] < self.plane.z:
            push = self.plane.stiffness * (self.plane.z - self.pose[2])
            self.force[2] += push
            if push > self.plane.protective_force and not self.protective_stopped:
                self.protective_stop(f"TCP force {push:.0f} N above the safety limit")

    # --- outputs --------------------------------------------------------------------------------
    def outputs(self) -> dict[str, object]:
        """All data fields a client may subscribe to, for this cycle."""
        with self.lock:
            safety_bits = 0
            if self.protective_stopped:
                safety_bits |= 1 << BIT_PROTECTIVE_STOPPED
            if self.estopped:
                safety_bits |= (1 << BIT_ESTOP) | (1 << BIT_ROBOT_ESTOP)
            if not safety_bits:
                safety_bits = 1 << BIT_NORMAL
            safety_mode = (SAFETY_ROBOT_EMERGENCY_STOP if self.estopped else
                           SAFETY_PROTECTIVE_STOP if self.protective_stopped else SAFETY_NORMAL)
            values: dict[str, object] = {
                "timestamp": self.now(),
                "actual_TCP_pose": list(self.pose), "target_TCP_pose": list(
                    self._target if self._target is not None and self._mode == "move" else self.pose),
                "actual_TCP_speed": list(self.velocity), "target_TCP_speed": list(self.velocity),
                "actual_TCP_force": list(self.force), "ft_raw_wrench": list(self.force),
                "actual_q": list(HOME_Q), "target_q": list(HOME_Q),
                "robot_mode": ROBOT_MODE_POWER_OFF if self.estopped else ROBOT_MODE_RUNNING,
                "joint_mode": [253] * 6, "safety_mode": safety_mode, "safety_status": safety_mode,
                "runtime_state": RUNTIME_PLAYING if self.program_running else RUNTIME_STOPPED,
                "robot_status_bits": 1 | (2 if self.program_running else 0),
                "safety_status_bits": safety_bits,
                "speed_scaling": 1.0, "target_speed_fraction": 1.0,
                "actual_main_voltage": 48.0, "actual_robot_voltage": 48.0,
                "joint_temperatures": [30.0] * 6, "actual_execution_time": 0.3,
            }
            for i in range(48):
                values[f"output_int_register_{i}"] = self.out_int[i]
                values[f"output_double_register_{i}"] = self.out_double[i]
            return values

    def status(self) -> dict:
        """A summary for the emulator's back door (tests and `state` queries)."""
        with self.lock:
            return {
                "pose": self.pose.tolist(), "velocity": self.velocity.tolist(),
                "force": self.force.tolist(), "mode": self._mode,
                "program_running": self.program_running,
                "protective_stopped": self.protective_stopped, "estopped": self.estopped,
                "watchdog_hz": self._watchdog_hz, "servo_updates": len(self.servo_updates),
                "servo_first": self.servo_updates[0] if self.servo_updates else None,
                "servo_last": self.servo_updates[-1] if self.servo_updates else None,
                "contact_z": self.plane.z,
                "events": [[t, e] for t, e in self.events[-50:]],
            }


def _rot_towards(start: np.ndarray, goal: np.ndarray, frac: float) -> np.ndarray:
    """Rotation vector a fraction `frac` of the way from `start` to `goal` (shortest arc)."""
    if frac >= 1.0:
        return np.array(goal, dtype=float)
    r0 = Rotation.from_rotvec(start)
    err = (Rotation.from_rotvec(goal) * r0.inv()).as_rotvec()
    if not np.any(err):
        return np.array(start, dtype=float)
    return (Rotation.from_rotvec(err * frac) * r0).as_rotvec()
