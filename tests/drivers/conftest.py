"""Fixtures for driver tests: emulator subprocesses on distinct loopback addresses, always killed."""

from __future__ import annotations

import pytest
from drivers_testkit import Emulator, next_host

from drivers.clock import WallClock
from drivers.emulators.launch import EmulatorProcess


@pytest.fixture
def start_ur():
    """Factory: start a UR controller emulator with extra CLI args; stopped after the test."""
    started: list[EmulatorProcess] = []

    def start(*args: str) -> Emulator:
        host = next_host()
        proc = EmulatorProcess("drivers.emulators.ur", ["--host", host, *args]).start()
        started.append(proc)
        return Emulator(proc, host, 30999)

    yield start
    for proc in started:
        proc.stop()


@pytest.fixture
def start_robotiq():
    """Factory: start a Robotiq emulator (framer tcp or rtu) with extra CLI args."""
    started: list[EmulatorProcess] = []

    def start(framer: str = "tcp", *args: str) -> Emulator:
        host = next_host()
        proc = EmulatorProcess("drivers.emulators.robotiq",
                               ["--host", host, "--port", "5020", "--framer", framer, *args]).start()
        started.append(proc)
        return Emulator(proc, host, 30998)

    yield start
    for proc in started:
        proc.stop()


@pytest.fixture
def clock() -> WallClock:
    return WallClock(1 / 30)
