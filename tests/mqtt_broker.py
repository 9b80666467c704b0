"""A real MQTT broker on loopback for the design-link tests: mosquitto (the Debian package; .ci/run
installs it) when it is installed, else amqtt (a Python broker from PyPI), on a free port, as a
child process the tests can kill and start again on the same port (a broker restart mid-run).

`Broker(directory)` is open (anonymous, plain MQTT), as a lab's first try would be.
`Broker(directory, secure=True)` is a lab's secured broker, mosquitto only: a password file
(mosquitto_passwd), the ACL file of examples/secure_broker (a cell publishes only on its own
topics, only the coordinator on the coordinator's), anonymous clients refused, and a second
listener speaking TLS with a server certificate from a throwaway CA made here with openssl; the
users, passwords and per-cell signing secrets are in `users` and written as credentials files by
`credentials(user)`."""

from __future__ import annotations

import json
import os
import secrets
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

START_TIMEOUT = 60.0  # s: a loaded machine may take long to import amqtt
ROOT = Path(__file__).resolve().parents[1]
ACL = ROOT / "examples" / "secure_broker" / "acl"
CELLS = ("A", "B")  # the cells of the secured broker (user name = cell name)
USERS = ("coordinator", "designer", *CELLS, "intruder")  # intruder: a lab laptop with an account


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def mosquitto() -> str | None:
    """mosquitto's path, or None (tests needing it skip with the reason)."""
    return shutil.which("mosquitto") or next(
        (p for p in ("/usr/sbin/mosquitto", "/usr/local/sbin/mosquitto") if os.access(p, os.X_OK)), None)


def make_certificates(directory: Path) -> dict[str, Path]:
    """A throwaway CA, a server certificate for 127.0.0.1/localhost signed by it, and a client
    certificate for the client-certificate option; paths by name."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = {name: directory / name for name in ("ca.key", "ca.crt", "server.key", "server.csr", "server.crt",
                                                   "client.key", "client.csr", "client.crt", "ext.cnf")}

    def openssl(*args: str) -> None:
        subprocess.run(["openssl", *args], check=True, capture_output=True, timeout=120)

    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj", "/CN=fvtree test CA",
            "-keyout", str(paths["ca.key"]), "-out", str(paths["ca.crt"]))
    paths["ext.cnf"].write_text("subjectAltName=IP:127.0.0.1,DNS:localhost\n")
    for who, cn in (("server", "127.0.0.1"), ("client", "A")):
        openssl("req", "-newkey", "rsa:2048", "-nodes", "-subj", f"/CN={cn}", "-keyout", str(paths[f"{who}.key"]),
                "-out", str(paths[f"{who}.csr"]))
        openssl("x509", "-req", "-in", str(paths[f"{who}.csr"]), "-CA", str(paths["ca.crt"]), "-CAkey",
                str(paths["ca.key"]), "-CAcreateserial", "-days", "2", "-out", str(paths[f"{who}.crt"]),
                *(["-extfile", str(paths["ext.cnf"])] if who == "server" else []))
    return paths


class Broker:
    """One broker process on 127.0.0.1:`port` (and, secured, TLS on `tls_port`), its files in `directory`."""

    def __init__(self, directory: Path, secure: bool = False):
        self.port = free_port()
        self.directory = directory
        self.secure = secure
        self.process: subprocess.Popen | None = None
        self.kind = "mosquitto" if mosquitto() else "amqtt"
        self.users: dict[str, dict[str, str]] = {}
        self.tls_port: int | None = None
        self.certs: dict[str, Path] = {}
        if secure:
            if self.kind != "mosquitto":
                pytest.skip("the secured broker needs mosquitto (apt-get install mosquitto; .ci/run does)")
            self._secure_files()

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    @property
    def tls_url(self) -> str:
        return f"mqtts://127.0.0.1:{self.tls_port}"

    def _secure_files(self) -> None:
        self.tls_port = free_port()
        self.certs = make_certificates(self.directory / "tls")
        passwd = self.directory / "passwd"
        passwd.write_text("")
        for user in USERS:
            self.users[user] = {"password": secrets.token_urlsafe(12), "secret": secrets.token_hex(32)}
            subprocess.run(["mosquitto_passwd", "-b", str(passwd), user, self.users[user]["password"]],
                           check=True, capture_output=True, timeout=60)

    def credentials(self, user: str, tls: bool = False, client_cert: bool = False) -> Path:
        """A credentials file for `user` (mode 0600): its login, its signing secret (a cell's), or
        every cell's secret (the coordinator's), and with `tls` the CA (and client certificate)."""
        entry: dict = {"username": user, "password": self.users[user]["password"]}
        if user == "coordinator":
            entry["cells"] = {c: self.users[c]["secret"] for c in CELLS}
        elif user in CELLS or user == "intruder":
            entry["secret"] = self.users[user]["secret"]
        if tls:
            entry["ca"] = str(self.certs["ca.crt"])
        if client_cert:
            entry.update(cert=str(self.certs["client.crt"]), key=str(self.certs["client.key"]))
        path = self.directory / f"{user}{'-tls' if tls else ''}{'-cert' if client_cert else ''}.json"
        path.write_text(json.dumps(entry))
        path.chmod(0o600)
        return path

    def _command(self) -> list[str]:
        if self.kind == "mosquitto":
            config = self.directory / "mosquitto.conf"
            if self.secure:
                config.write_text(
                    "per_listener_settings false\nallow_anonymous false\npersistence false\n"
                    + ("user root\n" if os.getuid() == 0 else "")  # root: read the test's 0700 files
                    + f"password_file {self.directory / 'passwd'}\nacl_file {ACL}\n"
                    f"listener {self.port} 127.0.0.1\n"
                    f"listener {self.tls_port} 127.0.0.1\ncafile {self.certs['ca.crt']}\n"
                    f"certfile {self.certs['server.crt']}\nkeyfile {self.certs['server.key']}\n"
                    "require_certificate false\ntls_version tlsv1.2\n")
            else:
                config.write_text(f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence false\n")
            return [str(mosquitto()), "-c", str(config)]
        config = self.directory / "amqtt.yaml"
        config.write_text(f"listeners:\n  default:\n    type: tcp\n    bind: 127.0.0.1:{self.port}\nplugins:\n"
                          "  amqtt.plugins.authentication.AnonymousAuthPlugin:\n    allow_anonymous: true\n")
        return [str(Path(sys.executable).with_name("amqtt")), "-c", str(config)]

    def start(self) -> Broker:
        log = open(self.directory / f"{self.kind}.log", "ab")  # noqa: SIM115 - the child holds it
        self.process = subprocess.Popen(self._command(), stdout=log, stderr=subprocess.STDOUT)
        log.close()
        deadline = time.monotonic() + START_TIMEOUT
        ports = [p for p in (self.port, self.tls_port) if p is not None]
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"{self.kind} exited with {self.process.returncode} on port {self.port}: "
                                   + (self.directory / f"{self.kind}.log").read_text()[-2000:])
            try:
                for port in ports:
                    with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                        pass
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
    """An open broker per test module (tests use their own cell names: retained plans do not mix)."""
    broker = Broker(tmp_path_factory.mktemp("broker")).start()
    yield broker
    broker.stop()


@pytest.fixture(scope="module", name="secure_broker")
def secure_broker_fixture(tmp_path_factory):
    """A secured mosquitto per test module: passwords, ACLs, TLS (see `Broker`)."""
    broker = Broker(tmp_path_factory.mktemp("secure-broker"), secure=True).start()
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
