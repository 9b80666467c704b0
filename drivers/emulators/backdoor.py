"""The emulators' back door: a line-based loopback port for what no real device offers over its
own protocol - injecting faults (protective stop, e-stop, dropped link, gripper fault) and reading
the emulator's ground truth. One request line in, one JSON line out."""

from __future__ import annotations

import json
import socket
import threading
from collections.abc import Callable

Handler = Callable[[str, list[str]], dict]


def serve(host: str, port: int, handler: Handler) -> socket.socket:
    """Serve `handler(command, args) -> dict` on host:port in daemon threads; returns the listener."""
    listener = socket.create_server((host, port), reuse_port=False)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)

    def client(conn: socket.socket) -> None:
        with conn, conn.makefile("rwb") as f:
            for raw in f:
                words = raw.decode(errors="replace").split()
                if not words:
                    continue
                try:
                    reply = handler(words[0], words[1:])
                except Exception as exc:  # noqa: BLE001 - report, never kill the emulator
                    reply = {"ok": False, "error": f"{type(exc).__name__}: {exc}"}
                f.write((json.dumps(reply) + "\n").encode())
                f.flush()

    def accept() -> None:
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            threading.Thread(target=client, args=(conn,), daemon=True).start()

    threading.Thread(target=accept, daemon=True, name="backdoor").start()
    return listener


class Client:
    """A kept-open back-door connection, for a caller that talks to the emulator every tick."""

    def __init__(self, host: str, port: int, timeout: float = 2.0):
        self.where = f"emulator back door at {host}:{port}"
        try:
            self._sock = socket.create_connection((host, port), timeout=timeout)
        except OSError as exc:
            raise ConnectionError(f"cannot reach the {self.where}: {exc} - is the emulator running?") from None
        self._file = self._sock.makefile("rwb")

    def call(self, line: str) -> dict:
        """Send one command line and return the emulator's JSON reply."""
        self._file.write((line.strip() + "\n").encode())
        self._file.flush()
        reply = self._file.readline()
        if not reply:
            raise ConnectionError(f"{self.where} closed without a reply")
        return json.loads(reply)

    def close(self) -> None:
        self._file.close()
        self._sock.close()


def call(host: str, port: int, line: str, timeout: float = 2.0) -> dict:
    """Send one back-door command on a fresh connection and return the emulator's JSON reply."""
    client = Client(host, port, timeout)
    try:
        return client.call(line)
    finally:
        client.close()
