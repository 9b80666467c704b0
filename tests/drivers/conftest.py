"""Fixtures for driver tests: emulator subprocesses on distinct loopback addresses, always killed."""

from __future__ import annotations

import pytest
from drivers_testkit import READY_TIMEOUT, Emulator, next_host

from drivers.clock import WallClock
from drivers.emulators.launch import EmulatorProcess


@pytest.fixture
def emulators():
    """Start emulator processes on fresh loopback addresses: `emulators(module, backdoor_port,
    *args)` -> Emulator; all of them are stopped after the test."""
    started: list[EmulatorProcess] = []

    def start(module: str, backdoor_port: int, *args: str) -> Emulator:
        host = next_host()
        proc = EmulatorProcess(module, ["--host", host, *args], ready_timeout=READY_TIMEOUT).start()
        started.append(proc)
        return Emulator(proc, host, backdoor_port)

    yield start
    for proc in started:
        proc.stop()


@pytest.fixture
def start_ur(emulators):
    """Factory: start a UR controller emulator with extra CLI args."""
    return lambda *args: emulators("drivers.emulators.ur", 30999, *args)


@pytest.fixture
def start_robotiq(emulators):
    """Factory: start a Robotiq emulator (framer tcp or rtu) with extra CLI args."""
    return lambda framer="tcp", *args: emulators("drivers.emulators.robotiq", 30998,
                                                 "--port", "5020", "--framer", framer, *args)


@pytest.fixture
def clock() -> WallClock:
    return WallClock(1 / 30)
