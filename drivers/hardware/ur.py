"""The Arm protocol on a Universal Robots arm through ur_rtde (control + receive interfaces).

Every control call runs on one worker thread and the caller waits at most a deadline, because
ur_rtde's blocking calls can hang after a link loss. A monitor thread polls the receive interface
at the controller rate and latches a fault when the controller timestamp stops advancing (the link
is gone; `isConnected()` is not trusted), on a protective or emergency stop, or when the control
script stops (e.g. the controller's RTDE watchdog fired). On a fault it asks the dashboard to stop
the program. It never unlocks a protective stop: a person does that on the teach pendant.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivers.hardware.ur_dashboard import Dashboard, DashboardError, controller_major, preflight
from drivers.protocols import Clock, DriverFault

log = logging.getLogger(__name__)

RECEIVE_FIELDS = ["timestamp", "actual_TCP_pose", "actual_TCP_speed", "actual_TCP_force",
                  "actual_q", "robot_mode", "safety_mode", "safety_status_bits", "runtime_state"]
PROTECTIVE_STOPPED_BIT, ROBOT_ESTOP_BIT, ESTOP_BIT = 1 << 2, 1 << 6, 1 << 7
RUNTIME_PLAYING = 2


@dataclass(frozen=True)
class UrConfig:
    """Connection and motion settings from the cell file's `arm:` section."""

    host: str
    acceleration: float = 0.5  # m/s^2 for linear moves and twists
    stop_deceleration: float = 2.0  # m/s^2 for stop()
    link_timeout: float = 0.06  # s without a new controller timestamp before the link counts as lost
    watchdog_hz: float = 10.0  # controller-side RTDE watchdog; 0 disables it
    command_timeout: float = 2.0  # s any non-streaming control call may take
    servo_lookahead: float = 0.1  # s, servoL lookahead_time in [0.03, 0.2]
    servo_gain: float = 300.0  # servoL gain in [100, 2000]
    dashboard_timeout: float = 1.0  # s per dashboard request

    def __post_init__(self):
        if not self.host:
            raise ValueError("arm.host is required (the robot's IP address)")
        if not 0.03 <= self.servo_lookahead <= 0.2 or not 100 <= self.servo_gain <= 2000:
            raise ValueError("servo_lookahead must be in [0.03, 0.2] s and servo_gain in [100, 2000]")
        for name in ("acceleration", "stop_deceleration", "link_timeout", "command_timeout"):
            if getattr(self, name) <= 0:
                raise ValueError(f"arm.{name} must be positive")


class _Job:
    """One call handed to the worker; its result or exception once `done` is set."""

    def __init__(self, what: str, fn: Callable[..., Any], args: tuple):
        self.what, self.fn, self.args = what, fn, args
        self.done = threading.Event()
        self.result: Any = None
        self.error: BaseException | None = None


class _Worker:
    """Runs ur_rtde control calls one at a time on a daemon thread, so callers can give up."""

    def __init__(self, name: str):
        self._jobs: queue.SimpleQueue[_Job | None] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while (job := self._jobs.get()) is not None:
            try:
                job.result = job.fn(*job.args)
            except BaseException as exc:  # noqa: BLE001 - handed to the waiting caller, who re-raises it
                job.error = exc
            job.done.set()

    def submit(self, what: str, fn: Callable[..., Any], *args) -> _Job:
        job = _Job(what, fn, args)
        self._jobs.put(job)
        return job

    def call(self, what: str, timeout: float, fn: Callable[..., Any], *args) -> Any:
        job = self.submit(what, fn, *args)
        if not job.done.wait(timeout):
            raise DriverFault(f"{what} did not return within {timeout:g} s (link or controller hung)")
        if job.error is not None:
            raise job.error
        return job.result

    def close(self, timeout: float = 1.0) -> None:
        """Finish the queued calls and end the thread (waiting at most `timeout` s)."""
        self._jobs.put(None)
        self._thread.join(timeout)


class UrArm:
    """A UR arm over ur_rtde. Commands are asynchronous; poll `is_moving()` and `fault()`."""

    def __init__(self, config: UrConfig, clock: Clock):
        import rtde_control
        import rtde_receive

        self.config = config
        self.clock = clock
        host = config.host
        try:
            info = preflight(host, config.dashboard_timeout)
        except DashboardError as exc:
            raise DriverFault(str(exc)) from None
        self.control_rate = 125.0 if controller_major(info["version"]) <= 3 else 500.0
        self._worker = _Worker(f"ur-control-{host}")
        try:
            self._receive = rtde_receive.RTDEReceiveInterface(host, self.control_rate, RECEIVE_FIELDS)
            self._control = rtde_control.RTDEControlInterface(host, self.control_rate)
        except RuntimeError as exc:
            self._worker.close()
            raise DriverFault(f"ur_rtde could not connect to {host}: {exc} - check that no other "
                              "RTDE client or fieldbus uses the input registers") from None
        self._lock = threading.RLock()
        self._fault: str | None = None
        self.fault_at: float | None = None  # time.monotonic() when the fault was detected
        self._mode = "idle"  # idle | move | speed | servo | contact
        self._twist: list[float] | None = None  # the held speedL twist, re-sent every tick
        self._contact: _Job | None = None
        self._contact_deadline = 0.0
        self._restart_script = False  # we stopped the program ourselves; re-upload before the next command
        self._snapshot = self._first_state_with_the_script(config.command_timeout)
        self._last_timestamp = self._snapshot["timestamp"]
        self._last_fresh = time.monotonic()
        self._stamp = clock.now()
        self._watchdog_armed = False  # armed by the first kick, i.e. when the tree starts ticking
        self._running = True
        self._monitor = threading.Thread(target=self._watch, name=f"ur-monitor-{host}", daemon=True)
        self._monitor.start()
        log.info("connected to UR at %s (%s, %g Hz)", host, info["version"], self.control_rate)

    # --- state --------------------------------------------------------------------------------------
    def pose(self) -> np.ndarray:
        return np.array(self._snapshot["pose"])

    def tcp_speed(self) -> np.ndarray:
        return np.array(self._snapshot["speed"])

    def tcp_wrench(self) -> np.ndarray:
        return np.array(self._snapshot["force"])

    def state_stamp(self) -> float:
        return self._stamp

    def fault(self) -> str | None:
        return self._fault

    def is_moving(self) -> bool:
        with self._lock:
            if self._mode == "contact":
                return self._poll_contact()
            if self._mode == "move" and self._control.getAsyncOperationProgress() < 0:
                self._mode = "idle"
        braking = self._mode == "speed" and not any(self._twist or ())  # a zero twist streamed
        return (self._mode != "idle" and not braking) or float(np.linalg.norm(self._snapshot["speed"][:3])) > 1e-3

    # --- commands -----------------------------------------------------------------------------------
    def move_linear(self, pose: np.ndarray, speed: float) -> None:
        self._command("moveL", "move", self._control.moveL, _vec(pose), float(speed),
                      self.config.acceleration, True)

    def speed_linear(self, twist: np.ndarray) -> None:
        v = _vec(twist)
        # A zero twist after a twist stays a streamed speedL, sent again with every kick as any held
        # twist is: a bare kick rewrites the command register, and a zero speedL the controller had
        # not read yet was lost (the arm went on at the old twist until the watchdog). Not speedStop:
        # it blocks until the arm has braked, ticks long on a real controller.
        streaming = any(v) or self._mode == "speed"
        self._command("speedL", "speed" if streaming else "idle", self._control.speedL, v,
                      self.config.acceleration, 0.0)
        self._twist = v if streaming else None

    def braking_distance(self, speed: float) -> float:
        """Metres the TCP travels while a twist of `speed` m/s is ramped to rest at the twist
        acceleration: what the safety layer adds to its one-period look-ahead at the box."""
        return speed * speed / (2.0 * self.config.acceleration)

    def servo_linear(self, pose: np.ndarray) -> None:
        """Stream one servo target; call once per control period (1 / control_rate)."""
        self._command("servoL", "servo", self._control.servoL, _vec(pose), 0.0, 0.0,
                      1.0 / self.control_rate, self.config.servo_lookahead, self.config.servo_gain)

    def stream_servo(self, target_at: Callable[[float], np.ndarray], duration: float) -> list[float]:
        """Stream servoL targets `target_at(t)` at the controller rate for `duration` s (deadline
        paced, no catch-up bursts), then servoStop; returns each command's latency in s."""
        period = 1.0 / self.control_rate
        latencies: list[float] = []
        start = time.perf_counter()
        next_at = start
        while (t := time.perf_counter() - start) < duration:
            sent = time.perf_counter()
            self.servo_linear(target_at(t))
            latencies.append(time.perf_counter() - sent)
            next_at += period
            delay = next_at - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            elif delay < -period:
                next_at = time.perf_counter()  # overran a whole period: do not burst to catch up
        self.stop()
        return latencies

    def move_until_contact(self, twist: np.ndarray, timeout: float) -> None:
        """Move at `twist` until the tool touches something (then back to the first contact
        point); fault if no contact within `timeout` s. Poll `is_moving()`."""
        with self._lock:
            self._prepare("moveUntilContact")
            relaxed = 1.0 / (timeout + 1.0)  # the controller watchdog must outlast the blocking call
            armed = self._watchdog_armed

            def job() -> bool:
                if armed:
                    self._control.setWatchdog(relaxed)
                ok = self._control.moveUntilContact(_vec(twist))
                if ok and armed:
                    self._control.setWatchdog(self.config.watchdog_hz)
                return ok

            self._contact = self._worker.submit("moveUntilContact", job)
            self._contact_deadline = self.clock.now() + timeout  # cell time, like the tree's
            self._mode = "contact"

    def stop(self) -> None:
        with self._lock:
            mode, self._mode = self._mode, "idle"
            if self._fault:
                return  # the controller already stopped, or cannot be reached over RTDE
            if mode == "contact" and self._contact and not self._contact.done.is_set():
                self._restart_script = True  # first, so the monitor expects the program to stop
                self._dashboard_stop("stop during moveUntilContact")
                return
            name, stop = {"speed": ("speedStop", self._control.speedStop),
                          "servo": ("servoStop", self._control.servoStop)}.get(
                mode, ("stopL", self._control.stopL))
            try:
                self._call(name, stop, self.config.stop_deceleration)
            except DriverFault as exc:
                self._latch(str(exc))

    def kick_watchdog(self) -> None:
        """Feed the controller's RTDE watchdog once per tree tick; the first kick arms it, so the
        controller stops the program whenever the ticks stop for longer than 1 / watchdog_hz."""
        with self._lock:
            if (self._fault or self._mode == "contact" or self._restart_script
                    or self.config.watchdog_hz <= 0):
                return
            try:
                if not self._watchdog_armed:
                    self._call("setWatchdog", self._control.setWatchdog, self.config.watchdog_hz)
                    self._watchdog_armed = True
                if self._mode == "speed" and self._twist is not None:
                    # speedL is a streamed command: ur_rtde does not wait for the controller to
                    # read it, and a bare kick rewrites the same register, so a held twist is
                    # sent again every tick (which also feeds the watchdog).
                    self._call("speedL", self._control.speedL, self._twist, self.config.acceleration, 0.0)
                else:
                    self._call("kickWatchdog", self._control.kickWatchdog)
            except DriverFault as exc:
                self._latch(str(exc))

    def close(self) -> None:
        """Stop motion and the control script, then disconnect (about 1 s: ur_rtde sleeps)."""
        self._running = False
        if not self._fault:
            self.stop()
            try:
                self._call("stopScript", self._control.stopScript)
            except DriverFault as exc:
                log.warning("%s", exc)
        for iface in (self._control, self._receive):
            try:
                self._worker.call("disconnect", self.config.command_timeout, iface.disconnect)
            except DriverFault as exc:
                log.warning("%s", exc)
        self._worker.close()
        self._monitor.join(timeout=1.0)
        # Destroy the ur_rtde interfaces here and now: their destructors sleep about a second
        # holding the GIL, which inside a later garbage collection would stall another cell's ticks.
        self._control = self._receive = None

    # --- internals ----------------------------------------------------------------------------------
    def _command(self, what: str, mode: str, fn: Callable[..., bool], *args) -> None:
        with self._lock:
            self._prepare(what)
            timeout = 0.5 if mode in ("servo", "speed") else self.config.command_timeout
            try:
                ok = self._call(what, fn, *args, timeout=timeout)
            except DriverFault as exc:
                self._latch(str(exc))
                raise
            if not ok:
                self._latch(f"UR {self.config.host}: the controller refused {what} "
                            f"({self._describe_state()})")
                raise DriverFault(self._fault)
            self._mode = mode

    def _prepare(self, what: str) -> None:
        if self._fault:
            raise DriverFault(f"{what} refused: {self._fault}")
        if self._mode == "contact" and not self._poll_contact_done():
            raise DriverFault(f"{what} refused: moveUntilContact still running; call stop() first")
        if self._restart_script:
            self._call("reuploadScript", self._control.reuploadScript)
            self._watchdog_armed = False  # a new script starts without a watchdog
            self._restart_script = False

    def _call(self, what: str, fn: Callable[..., Any], *args, timeout: float | None = None) -> Any:
        return self._worker.call(f"UR {self.config.host}: {what}",
                                 timeout or self.config.command_timeout, fn, *args)

    def _poll_contact_done(self) -> bool:
        return self._contact is None or self._contact.done.is_set()

    def _poll_contact(self) -> bool:
        job = self._contact
        if job.done.is_set():
            self._mode = "idle"
            if job.error is not None or not job.result:
                self._latch(f"UR {self.config.host}: moveUntilContact failed "
                            f"({job.error or self._describe_state()})")
            return False
        if self.clock.now() > self._contact_deadline:
            self.stop()
            self._latch(f"UR {self.config.host}: moveUntilContact found no contact in time")
            return False
        return True

    def _first_state_with_the_script(self, timeout: float) -> dict[str, Any]:
        """The first snapshot showing the control script running, or the last one after `timeout`
        s: the receive interface is an RTDE session of its own and may not have read the packets
        since the control interface started the script yet, so the monitor would take the script
        for stopped."""
        deadline = time.monotonic() + timeout
        snap = self._read_state()
        while snap["runtime"] != RUNTIME_PLAYING and time.monotonic() < deadline:
            time.sleep(1.0 / self.control_rate)
            snap = self._read_state()
        return snap

    def _read_state(self) -> dict[str, Any]:
        """One consistent snapshot: ur_rtde has no multi-field read, so re-read when a new
        packet arrived in between (the timestamp changed)."""
        r = self._receive
        for _ in range(3):
            stamp = r.getTimestamp()
            snap = {"connected": r.isConnected(), "timestamp": stamp, "pose": r.getActualTCPPose(),
                    "speed": r.getActualTCPSpeed(), "force": r.getActualTCPForce(),
                    "safety_bits": int(r.getSafetyStatusBits()), "runtime": int(r.getRuntimeState())}
            if r.getTimestamp() == stamp:
                break
        return snap

    def _watch(self) -> None:
        """Monitor thread: fresh data, safety stops, script state; latch the first fault."""
        period = 1.0 / self.control_rate
        while self._running:
            try:
                snap = self._read_state()
            except Exception as exc:  # noqa: BLE001 - a getter throwing after a link loss must not kill the monitor
                self._latch(f"UR {self.config.host}: lost RTDE link - cannot read the receive "
                            f"interface ({exc}); restart the cell to reconnect")
                time.sleep(period)
                continue
            now = time.monotonic()
            if snap["timestamp"] != self._last_timestamp:
                self._last_timestamp, self._last_fresh = snap["timestamp"], now
                self._stamp = self.clock.now()
                self._snapshot = snap
            if not self._fault:
                reason = self._check(snap, now - self._last_fresh)
                if reason:
                    self._latch(reason)
                    self._dashboard_stop(reason)
            time.sleep(period)

    def _check(self, snap: dict[str, Any], age: float) -> str | None:
        host = self.config.host
        if not snap["connected"] or age > self.config.link_timeout:
            # isConnected() can claim a dead link is up, so the data age is the real test; when it
            # does admit the socket closed, that is the earliest sign.
            why = "connection closed" if not snap["connected"] else f"no new controller data for {age:.3f} s"
            return (f"UR {host}: lost RTDE link - {why} (cable, network or controller down); "
                    "restart the cell to reconnect")
        if snap["safety_bits"] & (ESTOP_BIT | ROBOT_ESTOP_BIT):
            return (f"UR {host}: emergency stop - release the e-stop, power on the arm on the "
                    "teach pendant, then restart the cell")
        if snap["safety_bits"] & PROTECTIVE_STOPPED_BIT:
            return (f"UR {host}: protective stop - the controller stopped the arm; find the cause, "
                    "then unlock it on the teach pendant (this driver never unlocks it)")
        if snap["runtime"] != RUNTIME_PLAYING and not self._restart_script:
            return (f"UR {host}: control script stopped (the RTDE watchdog fired because the tree "
                    "stopped ticking, or the program was stopped on the pendant)")
        return None

    def _latch(self, reason: str) -> None:
        if self._fault is None:
            self._fault, self.fault_at = reason, time.monotonic()
            log.error("%s", reason)

    def _describe_state(self) -> str:
        snap = self._read_state()
        return f"safety status bits {snap['safety_bits']:#x}, runtime state {snap['runtime']}"

    def _dashboard_stop(self, why: str) -> None:
        """Fail-safe: stop the program over the dashboard, independent of the RTDE link."""
        try:
            with Dashboard(self.config.host, timeout=0.3) as d:
                reply = d.ask("stop")
            log.warning("dashboard stop (%s): %s", why, reply)
        except DashboardError as exc:
            log.warning("dashboard stop failed (%s): %s", why, exc)


def _vec(v) -> list[float]:
    out = [float(x) for x in np.asarray(v, dtype=float).ravel()]
    if len(out) != 6:
        raise ValueError(f"expected a 6-vector, got {len(out)} values")
    return out
