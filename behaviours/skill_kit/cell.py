"""What a skill may use of the cell `tree.setup(cell=...)` hands it: commands to the arm and the
gripper, their constants, and the clock. Skills never import the drivers (a contract in
pyproject.toml); any cell with these members will do, the drivers' `Cell` among them."""

from __future__ import annotations

from typing import Protocol

import numpy as np


class SkillArm(Protocol):
    def move_linear(self, pose: np.ndarray, speed: float) -> None:
        """Start a linear move to `pose` at `speed` m/s; returns at once."""

    def speed_linear(self, twist: np.ndarray) -> None:
        """Command a TCP twist, held until the next command or `stop`."""

    def stop(self) -> None:
        """Decelerate to standstill and drop any pending command."""

    @property
    def held_at(self) -> str | None:
        """The workspace box's face (e.g. "z min 0.35 m") where the safety layer stopped the last
        twist from going on, or None: a skill that moves until something happens checks it."""

    @property
    def clamped_target(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(requested, reachable) position of the last `move_linear` target the safety layer pulled
        into the workspace box, or None when it went where asked: a clamped move is a failure."""


class SkillGripper(Protocol):
    @property
    def max_width(self) -> float:
        """Metres between the fingertips, fully open."""

    @property
    def max_speed(self) -> float:
        """Fastest finger motion, m/s."""

    def move(self, width: float, speed: float = 0.05, force: float = 20.0) -> None:
        """Start moving the fingers to `width` (m) at `speed` (m/s) with grip `force` (N)."""

    def stop(self) -> None: ...


class SkillClock(Protocol):
    @property
    def period(self) -> float:
        """Seconds per tick."""

    def now(self) -> float:
        """Seconds on the cell's clock."""


class SkillCell(Protocol):
    @property
    def arm(self) -> SkillArm: ...

    @property
    def gripper(self) -> SkillGripper: ...

    @property
    def clock(self) -> SkillClock: ...
