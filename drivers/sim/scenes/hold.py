"""The hold scene: a box stands between the open fingers; once grasped and lifted off its stand
it hangs in the grip, and a second after the lift someone starts loading it (sand poured in),
so the grip that held the empty box starts to slip unless it is tightened. The box's material
(scene arg `object`, `drivers.sim.models.objects`) sets its friction and adhesion on the pads and
how far the markers move per newton."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.models.objects import GrippedObject
from drivers.sim.scenes import randomise
from drivers.sim.scenes.base import Scene
from drivers.sim.scenes.grip import (
    Grip,
    empty_contacts,
    object_grip,
    pad_contacts,
    pad_view,
    slip_signal,
    step_hand,
    tool_rotation,
)

GRAVITY = 9.81


@dataclass
class HoldScene(Scene):
    PROVIDES: ClassVar[frozenset[str] | None] = frozenset()  # for skills' NEEDS
    arm: SceneArm
    gripper: SceneGripper
    mass: float = 0.5  # kg, the empty box
    width: float = 0.04  # m across the fingers
    extra_load: float = 25.0  # N added once lifted: more than the gentle grasp carries
    load_start: float = 1.0  # s after the lift
    load_ramp: float = 4.0  # s to reach the full extra load
    finger_reach: float = 0.02  # m the box may slide before it leaves the pads
    view_half: float = 0.015  # m, half the camera window along the pad
    grip: Grip = field(default_factory=Grip)
    material: GrippedObject | None = None  # the box's (None: neutral, the cell's friction)

    def __post_init__(self):
        self._dt = 0.0  # s, length of the last tick (slip is motion per camera frame)
        self._start = self.arm.pose()[:3]
        self._lifted_at: float | None = None
        self._t = 0.0
        self.dropped = False
        self._load = np.zeros(3)

    def _weight(self) -> float:
        if self._lifted_at is None:
            return 0.0  # the stand carries the box
        ramp = np.clip((self._t - self._lifted_at - self.load_start) / self.load_ramp, 0.0, 1.0)
        return self.mass * GRAVITY + ramp * self.extra_load

    def step(self, dt: float) -> None:
        self._dt = dt
        step_hand(self.arm, self.gripper, None if self.dropped else self.width, dt)
        self._t += dt
        if self.dropped:
            return
        squeeze = self.gripper.squeeze_force()
        if self._lifted_at is None and squeeze > 0.0 and self.arm.pose()[2] - self._start[2] > 0.002:
            self._lifted_at = self._t
        self._load = tool_rotation(self.arm).T @ np.array([0.0, 0.0, -self._weight()])
        self.grip.step(self._load[[0, 2]], 2.0 * squeeze, dt)
        if np.hypot(*self.grip.slid) > self.finger_reach:
            self.dropped = True

    def contacts(self):
        if self.dropped:
            return empty_contacts()
        squeeze = self.gripper.squeeze_force()
        # The box is stuck to the skin while the grip holds: the camera sees it move with the
        # markers (the gel's shear, a fraction of a pixel), and beyond them only as far as it slid.
        offset = self.grip.slid / (2 * self.view_half)
        view = {s: pad_view(s, 0.3, offset) for s in (-1.0, 1.0)}
        slip = slip_signal(self.grip.speed, 0.3, self._dt)
        gain = self.material.marker_gain if self.material is not None else 1.0
        return pad_contacts((squeeze, squeeze), self._load, 0.0, (view[-1.0], view[1.0]), slip, gain=gain)

    # the grip the box must hang in at the end, and how far it may have slid in the pads
    TOLERANCES: ClassVar[dict[str, float]] = {"min_grip_N": 1.0, "max_slip_mm": 5.0}

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """Dropped, never lifted off the stand, hanging in less grip than `min_grip_N` at the end, or
        slid further than `max_slip_mm` in the pads."""
        if self.dropped:
            return ["the box was dropped"]
        grip = self.gripper.squeeze_force()
        if self._lifted_at is None:
            return [f"the box was never lifted off its stand (grip {grip:.2f} N)"]
        out = []
        if grip < tolerances["min_grip_N"]:
            out.append(f"the box ended in a grip of {grip:.2f} N < {tolerances['min_grip_N']:g} N")
        slid = float(np.hypot(*self.grip.slid)) * 1000
        if slid > tolerances["max_slip_mm"]:
            out.append(f"the box slid {slid:.1f} mm in the grip > {tolerances['max_slip_mm']:g} mm")
        return out

    def metrics(self) -> dict:
        return {"box slid (mm)": round(float(np.hypot(*self.grip.slid)) * 1000, 2),
                "box dropped": self.dropped,
                "load on the grip (N)": round(self._weight(), 2),
                "grip force (N)": round(self.gripper.squeeze_force(), 2)}


def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> HoldScene:
    """Scene args: mass (kg), extra_load (N), object (wood, glass, rubber, foam, steel; default a
    neutral box with the cell's friction)."""
    grip, material = object_grip(args, world)
    given = {"mass": args.get("mass", 0.5), "extra_load": args.get("extra_load", 25.0)}
    return HoldScene(arm, gripper, **randomise.params(HoldScene, "hold", given, world, seed),
                     grip=grip, material=material)
