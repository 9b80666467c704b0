"""A real MQTT broker on loopback for the design-link tests: mosquitto when it is installed,
else amqtt (a Python broker from PyPI), on a free port, as a child process the tests can kill and
start again on the same port (a broker restart mid-run)."""

from __future__ import annotations

import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

START_TIMEOUT = 60.0  # s: a loaded machine may take long to import amqtt


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Broker:
    """One broker process on 127.0.0.1:`port`, with its config in `directory`."""

    def __init__(self, directory: Path):
        self.port = free_port()
        self.directory = directory
        self.process: subprocess.Popen | None = None
        self.kind = "mosquitto" if shutil.which("mosquitto") else "amqtt"

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def _command(self) -> list[str]:
        if self.kind == "mosquitto":
            config = self.directory / "mosquitto.conf"
            config.write_text(f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence false\n")
            return [shutil.which("mosquitto"), "-c", str(config)]
        config = self.directory / "amqtt.yaml"
        config.write_text(f"listeners:\n  default:\n    type: tcp\n    bind: 127.0.0.1:{self.port}\nplugins:\n"
                          "  amqtt.plugins.authentication.AnonymousAuthPlugin:\n    allow_anonymous: true\n")
        return [str(Path(sys.executable).with_name("amqtt")), "-c", str(config)]

    def start(self) -> Broker:
        self.process = subprocess.Popen(self._command(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + START_TIMEOUT
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"{self.kind} exited with {self.process.returncode} on port {self.port}")
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.5):
                    return self
            except OSError:
                time.sleep(0.1)
        self.stop()
        raise RuntimeError(f"{self.kind} did not listen on port {self.port} within {START_TIMEOUT} s")

    def stop(self) -> None:
        """Kill it (no goodbye to the clients: like a crash or a pulled cable)."""
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait(timeout=30)
        self.process = None

    def restart(self, down: float = 1.0) -> None:
        self.stop()
        time.sleep(down)
        self.start()


@pytest.fixture(scope="module", name="mqtt_broker")
def mqtt_broker_fixture(tmp_path_factory):
    """A broker per test module (tests use their own cell names: retained plans do not mix)."""
    broker = Broker(tmp_path_factory.mktemp("broker")).start()
    yield broker
    broker.stop()


def wait_for(condition, timeout: float = 60.0, what: str = "a condition"):
    """Poll `condition()` until it is truthy (returned) or `timeout` s pass (a failed assert)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")
