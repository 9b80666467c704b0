"""Cell clocks: a simulated one that advances exactly one tick per step, and the wall clock."""

from __future__ import annotations

import time


class SimClock:
    """Simulated time: starts at 0 and advances only when the cell steps it."""

    def __init__(self, period: float):
        if period <= 0:
            raise ValueError(f"tick period must be positive, got {period}")
        self.period = period
        self.ticks = 0

    def now(self) -> float:
        return self.ticks * self.period

    def advance(self) -> None:
        self.ticks += 1


class WallClock:
    """Monotonic wall time for real cells; `advance` sleeps until the next tick boundary.

    With emulated devices running `time_scale` times faster than the wall clock, cell time runs
    at the same rate, so periods, timeouts and speeds keep their meaning."""

    def __init__(self, period: float, time_scale: float = 1.0):
        if period <= 0 or time_scale <= 0:
            raise ValueError(f"tick period and time scale must be positive, got {period}, {time_scale}")
        self.period = period
        self.time_scale = time_scale
        self._wall_period = period / time_scale
        self._t0 = time.monotonic()
        self._next = self._t0 + self._wall_period

    def now(self) -> float:
        return (time.monotonic() - self._t0) * self.time_scale

    def advance(self) -> None:
        delay = self._next - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        self._next = max(self._next + self._wall_period, time.monotonic())
