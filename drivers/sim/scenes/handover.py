"""The handover scene: a person brings a bottle between the open fingers, presses it on the
right pad and jiggles it until the robot has closed on it firmly enough to carry it (friction
beats 1.5 times its weight for `reaction` s), then lets go. `give_after` s later the person
takes it back: grips it and lifts with a force ramping up; once the fingers open past the
bottle, the person takes it away. If the grip cannot carry it, the bottle slides out and drops.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.models.fingervision_model import FingerContact
from drivers.sim.scenes import randomise
from drivers.sim.scenes.base import Scene
from drivers.sim.scenes.grip import Grip, empty_contacts, pad_contacts, pad_view, slip_signal, step_hand, tool_rotation

GRAVITY = 9.81


@dataclass
class HandoverScene(Scene):
    PROVIDES: ClassVar[frozenset[str] | None] = frozenset({"giver"})  # for skills' NEEDS
    arm: SceneArm
    gripper: SceneGripper
    mass: float = 0.3  # kg
    width: float = 0.05  # m across the fingers
    arrive: float = 1.0  # s until the bottle is between the fingers
    push: float = 4.0  # N the person presses the bottle on the right pad
    jiggle: float = 0.003  # m amplitude of the person's motion along the pads
    jiggle_hz: float = 1.5
    pad_shear_stiffness: float = 1000.0  # N/m, one pad
    reaction: float = 0.3  # s the person waits, feeling the grip, before letting go
    give_after: float = 3.0  # s after letting go until the person takes the bottle back (<0: never)
    lift: float = 8.0  # N the person lifts with when taking it back
    lift_ramp: float = 1.0  # s to reach that force
    area: float = 0.3
    pad_reach: float = 0.02
    grip: Grip = field(default_factory=Grip)

    def __post_init__(self):
        self._dt = 0.0  # s, length of the last tick (slip is motion per camera frame)
        self.phase = "approach"  # approach, offer, robot, taking, taken, dropped
        self._t = 0.0
        self._since = 0.0  # time the current phase started
        self._firm = 0.0  # how long the grip has been firm enough for the person
        self._load = np.zeros(3)
        self._held_slid = 0.0  # m the bottle slid in the pads while the robot held it, at most

    def _enter(self, phase: str) -> None:
        self.phase, self._since = phase, self._t

    def _between(self) -> bool:
        return self.phase in ("offer", "robot", "taking")

    def step(self, dt: float) -> None:
        self._dt = dt
        step_hand(self.arm, self.gripper, self.width if self._between() else None, dt)
        self._t += dt
        squeeze = self.gripper.squeeze_force()
        weight = self.mass * GRAVITY
        if self.phase == "approach" and self._t >= self.arrive:
            self._enter("offer")
        elif self.phase == "offer":
            self._firm = self._firm + dt if self.grip.capacity(2 * squeeze) >= 1.5 * weight else 0.0
            if self._firm >= self.reaction:
                self._enter("robot")
        elif self.phase == "robot" and 0.0 <= self.give_after <= self._t - self._since:
            self._enter("taking")
        elif self.phase == "taking" and squeeze <= 0.0:
            self._enter("taken")
        if self.phase in ("robot", "taking"):
            lift = min(1.0, (self._t - self._since) / self.lift_ramp) * self.lift if self.phase == "taking" else 0.0
            self._load = tool_rotation(self.arm).T @ np.array([0.0, 0.0, lift - weight])
            self.grip.step(self._load[[0, 2]], 2 * squeeze, dt)
            if self.phase == "robot":
                self._held_slid = max(self._held_slid, float(np.hypot(*self.grip.slid)))
            if np.hypot(*self.grip.slid) > self.pad_reach:
                self._enter("taken" if self.phase == "taking" else "dropped")

    def contacts(self):
        if not self._between():
            return empty_contacts()
        squeeze = self.gripper.squeeze_force()
        views = (pad_view(-1.0, self.area, (0.0, 0.0)), pad_view(1.0, self.area, (0.0, 0.0)))
        dt = self._dt
        if self.phase == "offer":
            # The person drags the right pad's gel as they jiggle the bottle against it.
            w = 2 * np.pi * self.jiggle_hz
            drag = np.clip(self.pad_shear_stiffness * self.jiggle * np.sin(w * self._t),
                           -self.grip.friction * self.push, self.grip.friction * self.push)
            slip = slip_signal(self.jiggle * w * np.cos(w * self._t), self.area, dt)
            return {"left": FingerContact(squeeze, np.zeros(2), 0.0, None, views[0], slip),
                    "right": FingerContact(squeeze + self.push, np.array([drag, 0.0]), 0.0, None, views[1], slip)}
        slip = slip_signal(self.grip.speed, self.area, dt)
        return pad_contacts((squeeze, squeeze), self._load, 0.0, views, slip)

    # how far the bottle may slide in the pads while the robot holds it
    TOLERANCES: ClassVar[dict[str, float]] = {"max_slip_mm": 5.0}

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """Dropped, never taken from the person, still held when the person pulled it back, or slid
        further than `max_slip_mm` while the robot held it."""
        if self.phase == "dropped":
            return ["the bottle was dropped"]
        if self.phase in ("approach", "offer"):
            return ["the robot never took the bottle: the person was still offering it"]
        out = []
        if self.phase == "taking":
            out.append("the person was taking the bottle back but the robot had not let go")
        if self._held_slid * 1000 > tolerances["max_slip_mm"]:
            out.append(f"the bottle slid {self._held_slid * 1000:.1f} mm in the grip while the robot held it > "
                       f"{tolerances['max_slip_mm']:g} mm")
        return out

    def metrics(self) -> dict:
        return {"bottle": {"approach": "not yet offered", "offer": "still offered by the person",
                           "robot": "held by the robot", "taking": "being taken back",
                           "taken": "taken back by the person", "dropped": "dropped"}[self.phase],
                "grip force (N)": round(self.gripper.squeeze_force(), 2)}


def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> HandoverScene:
    """Scene args: mass (kg), give_after (s; negative: the person never takes it back)."""
    given = {"mass": args.get("mass", 0.3)}
    return HandoverScene(arm, gripper, give_after=args.get("give_after", 3.0),
                         **randomise.params(HandoverScene, "handover", given, world, seed),
                         grip=Grip(friction=world.get("friction", 0.8)))
