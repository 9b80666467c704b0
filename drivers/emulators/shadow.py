"""A shadow world for an emulated cell (`perception: {source: shadow}`): the simulated scene a tree
needs (elements, plates, the ground) follows the emulated arm and gripper instead of moving them,
and gives the tree pixel-free FingerVision perception of what the fingertips touch.

The shadow also stands in for the physical world the emulators cannot see, through their back
doors: it tells the gripper emulator how wide the element between the fingers is, so the fingers
stop on it as a real Robotiq stops on a real element, and it hands the UR emulator the loads on
the held element, so the arm's force readback (and the safety layer's force limit) feels them.
A real Robotiq has no gel squeeze to measure: its grip force is the force setting of the last
move once it has stopped on the object.
"""

from __future__ import annotations

import numpy as np

from drivers.emulators.backdoor import Client
from drivers.protocols import DriverFault


def _ask(client: Client, line: str) -> None:
    reply = client.call(line)
    if not reply.get("ok"):
        raise DriverFault(f"{client.where} refused {line.split()[0]!r}: {reply.get('error')}")


class FollowedArm:
    """The arm as the simulated scene sees it: pose and speed read from the emulated arm, which
    the scene never moves (the emulator integrates the motion); the loads the scene puts on the
    TCP go to the emulator."""

    def __init__(self, arm, clock, backdoor: Client):
        self.arm, self.clock, self._backdoor = arm, clock, backdoor
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
    """The gripper as the simulated scene sees it: width and grip force from the Robotiq driver;
    the width of the object between the fingers goes to the gripper emulator."""

    def __init__(self, gripper, backdoor: Client):
        self.gripper, self._backdoor = gripper, backdoor
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
        """Normal force (N) on the object between the fingers; 0 with nothing there."""
        return self.gripper.grip_force() if self._object_width is not None else 0.0

    def step(self, dt: float) -> None:
        """Nothing to integrate: the gripper emulator moves the fingers."""
