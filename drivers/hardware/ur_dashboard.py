"""A minimal UR dashboard client (port 29999) with hard timeouts, for pre-flight checks, `fvtree
check` and the driver's fail-safe stop - independent of ur_rtde, whose calls can block."""

from __future__ import annotations

import socket

from drivers.protocols import DriverFault

DASHBOARD_PORT = 29999


class DashboardError(DriverFault, ConnectionError):
    """The dashboard server could not be reached or did not answer in time."""


class Dashboard:
    """One line-based dashboard session; every call is bounded by `timeout` seconds."""

    def __init__(self, host: str, timeout: float = 1.0):
        self.host = host
        self.timeout = timeout
        where = f"{host}:{DASHBOARD_PORT}"
        try:
            self._sock = socket.create_connection((host, DASHBOARD_PORT), timeout=timeout)
        except ConnectionRefusedError:
            raise DashboardError(f"cannot reach UR dashboard at {where}: connection refused - is the "
                                 "controller on, booted and in remote control?") from None
        except OSError as exc:
            raise DashboardError(f"cannot reach UR dashboard at {where}: {exc} - check the cable, "
                                 "the robot's IP address and that it is on") from None
        self._file = self._sock.makefile("rb")
        self.banner = self._readline()

    def _readline(self) -> str:
        try:
            line = self._file.readline()
        except OSError as exc:
            raise DashboardError(f"UR dashboard at {self.host} did not answer within "
                                 f"{self.timeout:g} s: {exc}") from None
        if not line:
            raise DashboardError(f"UR dashboard at {self.host} closed the connection")
        return line.decode(errors="replace").strip()

    def ask(self, command: str) -> str:
        """Send one command and return the reply line."""
        try:
            self._sock.sendall(command.encode() + b"\n")
        except OSError as exc:
            raise DashboardError(f"UR dashboard at {self.host}: cannot send {command!r}: {exc}") from None
        return self._readline()

    def close(self) -> None:
        self._file.close()
        self._sock.close()

    def __enter__(self) -> Dashboard:  # noqa: PYI034 - typing.Self needs Python 3.11
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def preflight(host: str, timeout: float = 1.0) -> dict[str, str]:
    """Read version, robot mode, safety status and remote control; raise DashboardError with what
    to do when the robot cannot take commands."""
    with Dashboard(host, timeout) as d:
        info = {"version": d.ask("PolyscopeVersion"), "robotmode": d.ask("robotmode"),
                "safety": d.ask("safetystatus"), "remote": d.ask("is in remote control")}
    if "RUNNING" not in info["robotmode"]:
        raise DashboardError(f"UR at {host} is not ready ({info['robotmode']}): power it on and "
                             "release the brakes on the teach pendant")
    if not any(s in info["safety"] for s in ("NORMAL", "REDUCED")):
        raise DashboardError(f"UR at {host} is safety-stopped ({info['safety']}): inspect the cell, "
                             "then clear the stop on the teach pendant")
    if "false" in info["remote"].lower():
        raise DashboardError(f"UR at {host} is in local control: switch it to remote control on "
                             "the teach pendant")
    return info


def controller_major(version_reply: str) -> int:
    """Major PolyScope version from a `PolyscopeVersion` reply such as 'URSoftware 5.11.1.108318'."""
    for word in version_reply.split():
        head = word.split(".")[0]
        if "." in word and head.isdigit():
            return int(head)
    raise DashboardError(f"unexpected PolyscopeVersion reply {version_reply!r}")
