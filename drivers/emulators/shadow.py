"""A shadow world for an emulated cell (`perception: {source: shadow}`): the simulated scene a tree
needs (elements, plates, the ground) follows the emulated arm and gripper instead of moving them,
and gives the tree pixel-free FingerVision perception of what the fingertips touch.

The shadow also stands in for the physical world the emulators cannot see, through their back
doors: it tells the gripper emulator how wide the element between the fingers is, so the fingers
stop on it as a real Robotiq with FingerVision pads stops on a real element (the pads give until
they press with the requested force), and it hands the UR emulator the loads on the held element,
so the arm's force readback (and the safety layer's force limit) feels them. The squeeze on the
element follows from the finger opening the Robotiq reports and the pad stiffness.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from drivers.cell import Cell
from drivers.cell_builders import CellRequest
from drivers.clock import WallClock
from drivers.emulators.backdoor import Client
from drivers.hardware.real_cell import closing_on_error, connect, parse
from drivers.protocols import Arm, DriverFault, Gripper
from drivers.sim.scenes import build_world, world_settings


def parse_shadow(path: Path, data: dict) -> dict:
    """The emulated cell file checked whole, with the shadow world's (sensor, world) settings
    under `perception.settings`."""
    spec = parse(path, data, shadow=True)
    spec["perception"]["settings"] = world_settings(path, spec["perception"], "perception.")
    return spec


def build_shadow_cell(path: Path, data: dict, request: CellRequest) -> Cell:
    """An emulated cell (`kind: real` on the loopback emulators) whose perception is the
    simulated `request.scene` following the emulated arm and gripper."""
    path = Path(path)
    spec = parse_shadow(path, data)
    settings = spec["perception"]["settings"]
    clock = WallClock(1.0 / request.tick_hz, spec["emulation"].time_scale)
    closers: list[Callable[[], None]] = []

    def build() -> Cell:
        devices = connect(spec, clock, closers)
        emulation = spec["emulation"]
        doors = [Client(spec["arm"].host, emulation.arm_backdoor_port),
                 Client(spec["gripper"].host, emulation.gripper_backdoor_port)]
        closers.extend(door.close for door in doors)
        world, _, sense = build_world(path, settings, FollowedArm(devices.arm, doors[0]),
                                      FollowedGripper(devices.gripper, doors[1], emulation.pad_stiffness), clock,
                                      request.scene, request.scene_args, request.seed)
        return Cell(spec["name"], devices.safe_arm, devices.safe_gripper, clock, sense, cameras=devices.cameras,
                    world=world, closers=closers)

    return closing_on_error(closers, build)


def _ask(client: Client, line: str) -> None:
    reply = client.call(line)
    if not reply.get("ok"):
        raise DriverFault(f"{client.where} refused {line.split()[0]!r}: {reply.get('error')}")


class FollowedArm:
    """The arm as the simulated scene sees it (a SceneArm): pose and speed read from the emulated
    arm, which the scene never moves (the emulator integrates the motion); the loads the scene
    puts on the TCP go to the emulator."""

    def __init__(self, arm: Arm, backdoor: Client):
        self.arm, self._backdoor = arm, backdoor
        self._wrench = np.zeros(6)
        _ask(backdoor, "external_wrench 0 0 0")

    @property
    def external_wrench(self) -> np.ndarray:
        return self._wrench.copy()

    @external_wrench.setter
    def external_wrench(self, wrench) -> None:
        wrench = np.asarray(wrench, dtype=float)
        if np.abs(wrench - self._wrench).max() > 1e-3:
            _ask(self._backdoor, "external_wrench " + " ".join(f"{w:.4f}" for w in wrench))
            self._wrench = wrench

    def pose(self) -> np.ndarray:
        return self.arm.pose()

    def tcp_speed(self) -> np.ndarray:
        return self.arm.tcp_speed()

    def step(self, dt: float) -> None:
        """Nothing to integrate: the emulated controller moves the arm."""


class FollowedGripper:
    """The gripper as the simulated scene sees it (a SceneGripper): the opening from the Robotiq
    driver, the squeeze from the opening and the pad stiffness; the width of the object between
    the fingers goes to the gripper emulator."""

    def __init__(self, gripper: Gripper, backdoor: Client, pad_stiffness: float):
        self.gripper, self._backdoor, self.pad_stiffness = gripper, backdoor, pad_stiffness
        self.max_width = gripper.max_width
        self._object_width: float | None = None
        _ask(backdoor, "object none")  # start from an empty hand, whatever an earlier run left

    @property
    def object_width(self) -> float | None:
        return self._object_width

    @object_width.setter
    def object_width(self, width: float | None) -> None:
        if width != self._object_width:
            _ask(self._backdoor, "object " + ("none" if width is None else repr(float(width))))
            self._object_width = width

    def width(self) -> float:
        return self.gripper.width()

    def squeeze_force(self) -> float:
        """Normal force (N) the pads press the object between the fingers with; 0 with nothing there."""
        if self._object_width is None:
            return 0.0
        return self.pad_stiffness * max(0.0, self._object_width - self.gripper.width())

    def step(self, dt: float) -> None:
        """Nothing to integrate: the gripper emulator moves the fingers."""
