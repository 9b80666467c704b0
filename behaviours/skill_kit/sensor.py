"""What a skill knows of its fingertip sensors: the cell's sensor profile (`perception.sensor_profile`:
gains in px per newton, rest jitter, the pipeline's slip response), read instead of carrying a
simulator's constants. A cell without one (a test double) gets the shipped default profile."""

from __future__ import annotations

from typing import Any

from perception.sensor_profile import SensorProfile, default_profile


def sensor_profile(cell: Any) -> SensorProfile:
    """The sensor profile of `cell` (its `sensor_profile`), or the default profile."""
    profile = getattr(cell, "sensor_profile", None)
    return profile if isinstance(profile, SensorProfile) else default_profile()
