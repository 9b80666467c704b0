"""UR controller emulator: RTDE on 30004, the dashboard on 29999 and the script port 30003, well
enough that the unmodified ur_rtde control and receive interfaces connect and run against it.

Run it in its own process (ur_rtde constructors hold the GIL, so an in-process server deadlocks):

    python -m drivers.emulators.ur --host 127.0.0.2 [--cb3] [--contact-z 0.1]
                                   [--backdoor-port 30999] [--dump-script FILE]

Options: `--host` loopback address to bind (ports are fixed, so use one 127.0.0.x per emulator);
`--cb3` reports controller major version 3 (125 Hz) instead of 5 (e-Series, 500 Hz);
`--contact-z` height of a horizontal contact plane (moveUntilContact stops on it, pushing into it
produces TCP force, more than `--protective-force` N trips a protective stop); `--stiffness` N/m;
`--backdoor-port` the line-based port for fault injection and ground truth (see backdoor.py):
`state`, `protective_stop`, `estop`, `estop_release`, `drop [SECONDS]` (close every connection;
refuse new ones for SECONDS), `contact_plane Z|none`; `--dump-script` saves the uploaded script.
The process prints `ready` once all ports listen, and exits on SIGTERM or SIGINT.
"""

from __future__ import annotations

import argparse
import signal
import socket
import struct
import sys
import threading
import time
from pathlib import Path

import numpy as np

from drivers.emulators import backdoor, rtde_wire
from drivers.emulators.ur_model import ContactPlane, UrModel
from drivers.loopback import is_loopback

DASHBOARD_PORT, SCRIPT_PORT, RTDE_PORT = 29999, 30003, 30004
VERSIONS = {3: (3, 15, 7, 106331), 5: (5, 11, 1, 108318)}
SEND_TIMEOUT = struct.pack("ll", 0, 20000)  # 20 ms: a client that stops reading is dropped


class RtdeSession:
    """One RTDE client: its negotiated recipes and whether it asked for data."""

    def __init__(self, sock: socket.socket):
        self.sock = sock
        self.send_lock = threading.Lock()
        self.output: rtde_wire.Recipe | None = None
        self.inputs: dict[int, rtde_wire.Recipe] = {}
        self.decimation = 1
        self.started = False
        self.alive = True

    def send(self, data: bytes) -> None:
        with self.send_lock:
            self.sock.sendall(data)

    def close(self) -> None:
        self.alive = False
        _close(self.sock)


class UrEmulator:
    """The three controller servers around one `UrModel`, plus the back door."""

    def __init__(self, host: str, model: UrModel, backdoor_port: int, dump_script: Path | None = None):
        self.host = host
        self.model = model
        self.backdoor_port = backdoor_port
        self.dump_script = dump_script
        self.sessions: list[RtdeSession] = []
        self.connections: list[socket.socket] = []  # dashboard and script clients
        self.listeners: dict[int, socket.socket] = {}
        self.lock = threading.Lock()
        self.stopping = threading.Event()

    # --- servers ----------------------------------------------------------------------------
    def listen(self) -> None:
        self._open_listeners()
        backdoor.serve(self.host, self.backdoor_port, self._backdoor)

    def _open_listeners(self) -> None:
        for port, handler in ((DASHBOARD_PORT, self._dashboard), (SCRIPT_PORT, self._script_sink),
                              (RTDE_PORT, self._rtde)):
            self.listeners[port] = socket.create_server((self.host, port))
            threading.Thread(target=self._accept, args=(port, handler), daemon=True).start()

    def _accept(self, port: int, handler) -> None:
        listener = self.listeners[port]
        while not self.stopping.is_set():
            try:
                conn, _ = listener.accept()
            except OSError:
                return  # listener closed (drop or shutdown)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            threading.Thread(target=handler, args=(conn,), daemon=True).start()

    def _track(self, conn: socket.socket) -> None:
        with self.lock:
            self.connections.append(conn)

    def _dashboard(self, conn: socket.socket) -> None:
        self._track(conn)
        try:
            conn.sendall(b"Connected: Universal Robots Dashboard Server\n")
            with conn.makefile("rb") as f:
                for raw in f:
                    command = raw.decode(errors="replace").strip()
                    conn.sendall((self._dashboard_reply(command) + "\n").encode())
                    if command == "quit":
                        return
        except OSError:
            pass
        finally:
            _close(conn)

    def _dashboard_reply(self, command: str) -> str:
        m = self.model
        status = m.status()
        safety = ("ROBOT_EMERGENCY_STOP" if status["estopped"] else
                  "PROTECTIVE_STOP" if status["protective_stopped"] else "NORMAL")
        version = ".".join(map(str, VERSIONS[5 if m.major_version > 3 else 3]))
        running = status["program_running"]
        replies = {
            "PolyscopeVersion": f"URSoftware {version} (Mar 22 2022)",
            "get serial number": "20205500001",
            "is in remote control": "true",
            "robotmode": "Robotmode: " + ("POWER_OFF" if status["estopped"] else "RUNNING"),
            "safetystatus": f"Safetystatus: {safety}",
            "safetymode": f"Safetymode: {safety}",
            "running": f"Program running: {str(running).lower()}",
            "programState": ("PLAYING" if running else "STOPPED") + " rtde_control",
            "close safety popup": "closing safety popup",
            "close popup": "closing popup",
            "power on": "Powering on",
            "brake release": "Brake releasing",
            "quit": "Disconnected",
        }
        if command == "stop":
            if not running:
                return "Failed to execute: stop"
            m.stop_program("dashboard stop")
            return "Stopped"
        if command == "pause":
            m.stop_program("dashboard pause")
            return "Pausing program"
        if command == "play":
            return "Failed to execute: play"  # no .urp program is loaded on the emulator
        if command == "unlock protective stop":
            return ("Protective stop releasing" if m.unlock_protective_stop()
                    else "Cannot unlock protective stop, the robot is not protective stopped")
        return replies.get(command, f"Could not understand: '{command}'")

    def _script_sink(self, conn: socket.socket) -> None:
        """Port 30003: a burst of script text ending in a pause runs as the new program."""
        self._track(conn)
        conn.settimeout(0.05)
        buf = bytearray()
        try:
            while not self.stopping.is_set():
                try:
                    chunk = conn.recv(65536)
                except TimeoutError:
                    chunk = None
                if chunk:
                    buf += chunk
                    continue
                if buf:
                    self._run_script(bytes(buf))
                    buf.clear()
                if chunk == b"":
                    return
        except OSError:
            pass
        finally:
            _close(conn)

    def _run_script(self, text: bytes) -> None:
        if self.dump_script:
            self.dump_script.write_bytes(text)
        if b"def " in text:
            self.model.start_program()

    def _rtde(self, conn: socket.socket) -> None:
        conn.setsockopt(socket.SOL_SOCKET, socket.SO_SNDTIMEO, SEND_TIMEOUT)
        session = RtdeSession(conn)
        with self.lock:
            self.sessions.append(session)
        try:
            while session.alive:
                msg_type, body = rtde_wire.read_message(conn)
                reply = self._rtde_reply(session, msg_type, body)
                if reply is not None:
                    session.send(reply)
        except (OSError, ConnectionError, struct.error, KeyError):
            pass
        finally:
            session.close()
            with self.lock:
                if session in self.sessions:
                    self.sessions.remove(session)

    def _rtde_reply(self, session: RtdeSession, msg_type: int, body: bytes) -> bytes | None:
        w = rtde_wire
        if msg_type == w.REQUEST_PROTOCOL_VERSION:
            return w.pack(msg_type, b"\x01")
        if msg_type == w.GET_URCONTROL_VERSION:
            major = 5 if self.model.major_version > 3 else 3
            return w.pack(msg_type, struct.pack(">IIII", *VERSIONS[major]))
        if msg_type == w.SETUP_OUTPUTS:
            (frequency,) = struct.unpack(">d", body[:8])
            recipe = w.Recipe(1, _names(body[8:]))
            session.output = recipe
            rate = 1.0 / self.model.period
            session.decimation = max(1, round(rate / frequency)) if frequency > 0 else 1
            return w.pack(msg_type, bytes([recipe.id]) + recipe.types_text().encode())
        if msg_type == w.SETUP_INPUTS:
            recipe = w.Recipe(len(session.inputs) + 1, _names(body))
            session.inputs[recipe.id] = recipe
            return w.pack(msg_type, bytes([recipe.id]) + recipe.types_text().encode())
        if msg_type == w.START:
            session.started = session.output is not None and session.output.valid
            return w.pack(msg_type, bytes([int(session.started)]))
        if msg_type == w.PAUSE:
            session.started = False
            return w.pack(msg_type, b"\x01")
        if msg_type == w.DATA_PACKAGE:
            self.model.write_inputs(session.inputs[body[0]].unpack(body[1:]))
            return None
        return w.pack(w.TEXT_MESSAGE, b"unknown message type")

    # --- back door ------------------------------------------------------------------------------
    def _backdoor(self, command: str, args: list[str]) -> dict:
        m = self.model
        now = time.monotonic()
        if command == "state":
            return {"ok": True, "t": now, **m.status()}
        if command == "protective_stop":
            m.protective_stop("injected")
        elif command == "estop":
            m.emergency_stop()
        elif command == "estop_release":
            m.release_emergency_stop()
        elif command == "drop":
            self.drop(float(args[0]) if args else 0.0)
        elif command == "external_wrench":
            if not 3 <= len(args) <= 6:
                return {"ok": False, "error": "external_wrench takes FX FY FZ [TX TY TZ] (N, N m)"}
            wrench = _finite(args) + [0.0] * (6 - len(args))
            with m.lock:
                m.external_wrench = np.array(wrench)
        elif command == "contact_plane":
            z = None if args[0] == "none" else _finite(args[:1])[0]
            with m.lock:
                m.plane.z = z
        else:
            return {"ok": False, "error": f"unknown command {command!r}; known: state, "
                    "protective_stop, estop, estop_release, drop [s], contact_plane Z|none, "
                    "external_wrench FX FY FZ [TX TY TZ]"}
        return {"ok": True, "t": now}

    def drop(self, refuse_for: float) -> None:
        """Cut every client connection, like a pulled cable; refuse new ones for `refuse_for` s."""
        self.model._event(f"connections dropped (refusing for {refuse_for:g} s)")
        if refuse_for > 0:
            for listener in self.listeners.values():
                _close(listener)
        with self.lock:
            sessions, conns = list(self.sessions), list(self.connections)
            self.connections.clear()
        for s in sessions:
            s.close()
        for c in conns:
            _close(c)
        if refuse_for > 0:
            timer = threading.Timer(refuse_for, self._relisten)
            timer.daemon = True
            timer.start()

    def _relisten(self) -> None:
        if not self.stopping.is_set():
            self._open_listeners()

    # --- the controller loop ----------------------------------------------------------------------
    def run(self) -> None:
        """Step the model and stream data packages every controller cycle until stopped."""
        period = self.model.period
        emulated = period * self.model.time_scale  # emulated seconds per controller cycle
        cycle = 0
        deadline = time.monotonic()
        while not self.stopping.is_set():
            deadline += period
            self.model.step(emulated)
            values = self.model.outputs()
            with self.lock:
                sessions = [s for s in self.sessions if s.started]
            for s in sessions:
                if cycle % s.decimation == 0:
                    try:
                        s.send(rtde_wire.pack(rtde_wire.DATA_PACKAGE, s.output.pack(values)))
                    except OSError:
                        s.close()
            cycle += 1
            delay = deadline - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            elif delay < -0.1:
                deadline = time.monotonic()  # fell far behind (machine overloaded): resynchronise

    def shutdown(self) -> None:
        self.stopping.set()
        for listener in self.listeners.values():
            _close(listener)
        self.drop(0.0)


def _finite(words: list[str]) -> list[float]:
    """Back-door arguments as finite numbers; a ValueError (an error reply) otherwise."""
    values = [float(w) for w in words]
    if not np.all(np.isfinite(values)):
        raise ValueError(f"values must be finite, got {' '.join(words)}")
    return values


def _names(raw: bytes) -> list[str]:
    return [n for n in raw.decode().split(",") if n]


def _close(sock: socket.socket) -> None:
    try:
        sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    sock.close()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m drivers.emulators.ur", description=__doc__.split("\n\n")[0])
    p.add_argument("--host", default="127.0.0.2", help="loopback address to bind (default 127.0.0.2)")
    p.add_argument("--cb3", action="store_true", help="act as a CB3 controller (125 Hz)")
    p.add_argument("--contact-z", type=float, default=None, help="height of the contact plane (m)")
    p.add_argument("--stiffness", type=float, default=20000.0, help="contact stiffness (N/m)")
    p.add_argument("--protective-force", type=float, default=300.0,
                   help="TCP force that trips a protective stop (N)")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="emulated seconds per wall-clock second (speeds up long runs in tests)")
    p.add_argument("--backdoor-port", type=int, default=30999, help="fault-injection port")
    p.add_argument("--dump-script", type=Path, default=None, help="save the uploaded script here")
    args = p.parse_args(argv)
    if not is_loopback(args.host):
        p.error("the emulator binds loopback addresses only (127.0.0.0/8, ::1, localhost)")
    if args.time_scale <= 0:
        p.error("--time-scale must be positive")
    model = UrModel(3 if args.cb3 else 5, ContactPlane(args.contact_z, args.stiffness, args.protective_force),
                    args.time_scale)
    emulator = UrEmulator(args.host, model, args.backdoor_port, args.dump_script)
    try:
        emulator.listen()
    except OSError as exc:
        print(f"cannot listen on {args.host}: {exc} - is another emulator using this address?",
              file=sys.stderr)
        return 2
    signal.signal(signal.SIGTERM, lambda *_: emulator.stopping.set())
    signal.signal(signal.SIGINT, lambda *_: emulator.stopping.set())
    print("ready", flush=True)
    emulator.run()
    emulator.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
