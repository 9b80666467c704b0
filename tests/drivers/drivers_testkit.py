"""Helpers for the driver tests (a uniquely named module: conftest.py names are ambiguous)."""

from __future__ import annotations

import contextlib
import itertools
import os
import time

from drivers.emulators import backdoor
from drivers.emulators.__main__ import cell_emulators
from drivers.emulators.launch import EmulatorProcess

_hosts = itertools.count(10)


def next_host() -> str:
    """A fresh loopback address per emulator: the UR ports are fixed, so addresses must differ,
    also between test workers and sessions running at the same time (hence the process id, in two
    octets: no two live processes share them while process ids stay below 62 500)."""
    pid = os.getpid()
    return f"127.{pid // 250 % 250 + 1}.{pid % 250}.{next(_hosts) % 250 + 1}"


class Emulator:
    """A running emulator: its address and its back door."""

    def __init__(self, process: EmulatorProcess, host: str, backdoor_port: int):
        self.process, self.host, self.backdoor_port = process, host, backdoor_port

    def call(self, line: str) -> dict:
        reply = backdoor.call(self.host, self.backdoor_port, line)
        assert reply.get("ok"), reply
        return reply

    def state(self) -> dict:
        return self.call("state")


WALL_SLACK = 10.0  # s of wall time a loaded two-core machine may leave a thread unscheduled
DEADLINE = 60.0  # s an awaited outcome may take on a loaded machine (a wait ends as soon as it holds)
READY_TIMEOUT = 120.0  # s an emulator may take to start (import and listen) on a loaded machine


def tolerant_of_load(data: dict, time_scale: float = 1.0) -> dict:
    """A real cell file's mapping with every timeout that measures scheduling rather than the
    devices (the controller's RTDE watchdog, the drivers' link, command, dashboard and Modbus
    timeouts, the safety layer's watchdog and data age, the supervisor's perception age) raised to
    WALL_SLACK s of wall time, so that a busy test machine never stops the cell; `time_scale` is
    the emulators' speed-up."""
    cell_seconds = WALL_SLACK * time_scale
    data["arm"].update(watchdog_hz=1.0 / cell_seconds, link_timeout=WALL_SLACK, command_timeout=WALL_SLACK,
                       dashboard_timeout=WALL_SLACK)
    data["gripper"].update(timeout=WALL_SLACK, activation_timeout=WALL_SLACK)
    data["safety"].update(watchdog_timeout=cell_seconds, stale_after=cell_seconds)
    data["supervision"] = {"perception_stale_after": cell_seconds}
    return data


def wait_until(predicate, timeout: float, step: float = 0.005) -> bool:
    """Poll `predicate` until it holds or `timeout` s pass; returns whether it held."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(step)
    return bool(predicate())


@contextlib.contextmanager
def emulating(cell_file, **options):
    """The emulators a cell file points at, running for the with-block; always stopped."""
    procs = cell_emulators(cell_file, **options)
    try:
        for proc in procs:
            proc.ready_timeout = READY_TIMEOUT
            proc.start()
        yield procs
    finally:
        for proc in reversed(procs):
            proc.stop()
