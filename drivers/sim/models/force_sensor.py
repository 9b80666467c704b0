"""The arm's TCP force sensor as a UR e-Series reads it: the scene's force plus an offset, a slow
drift and noise, with zeroing.

A UR's built-in TCP force reads a pose- and payload-dependent offset (a lifted 4 kg weight read
35.5 N on a CB-series arm against 28.0 N on an external sensor: 7.5 N off; an e-Series arm held a
10 N set point at 8.95-13.26 N depending on pose), noise (CB: 3.6 N std on that weight; e-Series:
a mean deviation of 0.38 N over 1-10 N, Trochimczuk et al.) and drifts with temperature; ur_rtde's
`zeroFtSensor()` takes the present reading as zero. Defaults (the sim cell file's `force_sensor:`):
`offset` 5 N (range 0-10 N) in a direction drawn per seed, `drift` 0.5 N per minute (no published
figure; range 0-2), `noise` 0.4 N std per axis (range 0.2-3.6). All zero: the ideal sensor.

`ForceSensedArm` wraps the simulated arm: everything passes through except `tcp_wrench`; the
noise is drawn once per tick of the cell clock, so every reader of one tick sees the same value.
A reading is six numbers a few times a tick, so it is worked out on Python floats (the same
operations in the same order as on arrays: the same floats) and the noise is drawn NOISE_DRAWS ticks
at a time (one generator call gives the same numbers in the same order as a call per tick)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from drivers.clock import SimClock

NOISE_DRAWS = 256  # ticks of sensor noise drawn from the generator at a time
NO_NOISE = [0.0, 0.0, 0.0]


@dataclass(frozen=True)
class ForceSensorConfig:
    """Errors of the TCP force reading (N; drift in N per minute)."""

    offset: float = 5.0
    drift: float = 0.5
    noise: float = 0.4

    def __post_init__(self) -> None:
        for name in ("offset", "drift", "noise"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not value >= 0.0:
                raise ValueError(f"force_sensor.{name} must be a number >= 0, got {value!r}")


class SensorErrors:
    """Offset + drift + noise of one force sensor with the errors of `config`: `at(now)` is the error
    (N, N m) at cell time `now`, its noise drawn once per tick of the cell clock."""

    def __init__(self, config: ForceSensorConfig, seed: int):
        self._config = config
        self._rng = np.random.default_rng([seed, 0xF7])
        self._offset = [*(config.offset * _unit(self._rng)).tolist(), 0.0, 0.0, 0.0]  # N on the force axes only
        self._drift = [*(config.drift / 60.0 * _unit(self._rng)).tolist(), 0.0, 0.0, 0.0]
        self._time: float | None = None  # the cell time of the last error worked out
        self._error: list[float] = []
        self._noise: list[list[float]] = []  # the noise of the ticks to come, next last

    def at(self, now: float) -> list[float]:
        if self._time != now:
            noise = [*self._next_noise(), 0.0, 0.0, 0.0]
            self._time, self._error = now, [o + d * now + n for o, d, n in zip(self._offset, self._drift, noise)]
        return self._error

    def _next_noise(self) -> list[float]:
        """The next tick's force noise (N, x y z): `noise * standard_normal(3)`, drawn in blocks."""
        if not self._config.noise:
            return NO_NOISE
        if not self._noise:
            self._noise = (self._config.noise * self._rng.standard_normal((NOISE_DRAWS, 3))).tolist()[::-1]
        return self._noise.pop()


class ForceSensedArm:
    """`arm` with its `tcp_wrench` read through a sensor with the errors of `config`."""

    def __init__(self, arm: Any, clock: SimClock, config: ForceSensorConfig, seed: int):
        self._arm, self._clock = arm, clock
        self._errors = SensorErrors(config, seed)
        self._bias = [0.0] * 6  # what the last zeroing subtracts

    def __getattr__(self, name: str) -> Any:
        return getattr(self._arm, name)

    def __setattr__(self, name: str, value: Any) -> None:
        """The wrapper's own state is private; anything else (a fault injected by a test, the
        scene's external wrench) is the arm's."""
        if name.startswith("_"):
            object.__setattr__(self, name, value)
        else:
            setattr(self._arm, name, value)

    # The reads the safety layer makes every tick, passed on directly rather than through __getattr__.
    def pose(self) -> np.ndarray:
        return self._arm.pose()

    def state_stamp(self) -> float:
        return self._arm.state_stamp()

    def is_moving(self) -> bool:
        return self._arm.is_moving()

    def fault(self) -> str | None:
        return self._arm.fault()

    def tcp_wrench(self) -> np.ndarray:
        """The reading: the scene's force and torque plus the sensor's errors, minus the last zeroing."""
        w0, w1, w2, w3, w4, w5 = self._arm.tcp_wrench().tolist()
        e, b = self._errors.at(self._clock.now()), self._bias
        # Written out: a list comprehension over six numbers costs a call of its own, twice a tick.
        return np.array([w0 + e[0] - b[0], w1 + e[1] - b[1], w2 + e[2] - b[2],
                         w3 + e[3] - b[3], w4 + e[4] - b[4], w5 + e[5] - b[5]])

    def zero_ft_sensor(self) -> None:
        """Take the present reading as zero (ur_rtde's `zeroFtSensor`): the offset and the drift so far
        go; the noise and the load the arm feels now are folded into the zero as on a real arm."""
        self._bias = [w + e for w, e in zip(self._arm.tcp_wrench().tolist(), self._errors.at(self._clock.now()))]


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)
