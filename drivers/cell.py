"""A cell bundles arm, gripper, cameras, clock, the perception source and, in simulation, the
world: everything a tree acts on. Cell files (`drivers/cells/*.yaml`) say how to build one."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from drivers.clock import SimClock, WallClock
from drivers.protocols import Camera, PerceptionSource, World
from drivers.safe_gripper import SafeGripper
from drivers.safety import SafeArm
from perception.sensor_profile import SensorProfile, default_profile


@dataclass
class Cell:
    """Everything a tree acts on. Skills receive it through `tree.setup(cell=...)`."""

    name: str
    arm: SafeArm
    gripper: SafeGripper
    clock: SimClock | WallClock
    sense: PerceptionSource  # fills /fv/<finger> each tick
    cameras: dict[str, Camera] = field(default_factory=dict)
    world: World | None = None  # the simulated scene (on an emulated cell, its shadow); None on hardware
    estop: bool = False  # set by an e-stop input; the runner halts the tree when it is set
    closers: list[Callable[[], None]] = field(default_factory=list)
    # The fingertips' sensor profile (gains, rest jitter, ...), which skills read instead of constants;
    # a simulated cell's is the one its file names (`sensor.profile`), other cells' the default.
    sensor_profile: SensorProfile = field(default_factory=default_profile)
    # Takes the arm's present TCP force reading as zero (ur_rtde's zeroFtSensor); None where the cell's
    # arm driver offers none (the hardware driver passes the UR's reading raw: skills take a baseline).
    zero_force_sensor: Callable[[], None] | None = None

    @property
    def simulated(self) -> bool:
        """Time is simulated: the cell advances only when stepped (the runner may pace it)."""
        return isinstance(self.clock, SimClock)

    def step(self) -> None:
        """Advance one tick: the world integrates the commands, the clock moves on, and the
        safety layer checks force, faults, watchdog and data age."""
        if self.world is not None:
            self.world.step(self.clock.period)
        self.clock.advance()
        self.arm.supervise()

    def close(self) -> None:
        """Stop arm and gripper, then release every device in reverse order of opening."""
        self.arm.stop()
        self.gripper.stop()
        for close in reversed(self.closers):
            close()
