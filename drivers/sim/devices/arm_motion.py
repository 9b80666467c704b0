"""How the simulated arm's TCP answers a command, as a UR controller does: the command takes effect
`latency` seconds after it is sent, and the TCP's velocity then follows it within an acceleration
limit (no instant speed changes), linear and angular alike.

Defaults (the sim cell file's `arm:` section) and where they come from:

- `acceleration` 0.5 m/s^2 (range 0.25-1.2): what this project's UR driver commands for moveL and
  speedL (`drivers/hardware/ur.py`, `arm.acceleration`), so the simulated arm accelerates as the
  real one is told to; ur_rtde's speedL default is 0.25 and URScript's movel default 1.2 m/s^2.
- `angular_acceleration` 0.5 rad/s^2 (range 0.25-1.2): URScript's speedl applies its acceleration
  to the rotation too unless `aRot` is given, and ur_rtde's speedL does not give it.
- `stop_deceleration` 2.0 m/s^2 (rad/s^2 for rotation; range 1-4): the driver's `stop_deceleration`
  for stopL.
- `latency` 0.008 s (range 0.002-0.033): an e-Series controller reads RTDE inputs once per 2 ms
  cycle (500 Hz) and its trajectory generator acts a cycle or more later: 2-8 ms from the call to
  motion; the default takes the slow end (a skill that holds at 8 ms holds at 2), the range runs to
  one tree tick at 30 Hz (a CB3 at 125 Hz has 8 ms cycles).

All zero: the kinematic arm of earlier rounds (velocity changes within a tick, at once); the mocked
cells of the tests keep that.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

CONTROL_PERIOD = 0.002  # s, a UR e-Series controller cycle (500 Hz): the sub-step while accelerating


@dataclass(frozen=True)
class ArmMotion:
    """Acceleration limits (0: none) and command latency of the simulated arm."""

    acceleration: float = 0.5  # m/s^2
    angular_acceleration: float = 0.5  # rad/s^2
    stop_deceleration: float = 2.0  # m/s^2 and rad/s^2
    latency: float = 0.008  # s

    def __post_init__(self) -> None:
        for name in ("acceleration", "angular_acceleration", "stop_deceleration", "latency"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not 0.0 <= value < math.inf:
                raise ValueError(f"arm.{name} must be a number >= 0, got {value!r}")
        if self.latency > 1.0:
            raise ValueError(f"arm.latency must be at most 1 s, got {self.latency!r}")

    @property
    def ideal(self) -> bool:
        """No latency and no acceleration limit: the kinematic arm."""
        return not (self.acceleration or self.angular_acceleration or self.stop_deceleration or self.latency)


IDEAL = ArmMotion(0.0, 0.0, 0.0, 0.0)


def ramp(current: list[float], goal: list[float], max_change: float) -> list[float]:
    """`current` moved towards `goal` by at most `max_change` in norm (0: no limit, reach it)."""
    d = [g - c for g, c in zip(goal, current)]
    n = math.hypot(*d)
    if max_change <= 0.0 or n <= max_change:
        return list(goal)
    k = max_change / n
    return [c + x * k for c, x in zip(current, d)]


def approach_speed(distance: float, cruise: float, accel: float, h: float) -> float:
    """Speed to head for a point `distance` away at: `cruise`, but no faster than lets the arm stop
    there at `accel` (with no limit: cover the distance in this sub-step `h` at most)."""
    if accel <= 0.0:
        return min(cruise, distance / h)
    return min(cruise, math.sqrt(2.0 * accel * distance))
