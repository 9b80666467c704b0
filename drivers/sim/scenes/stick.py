"""The stick scenes: a stick grasped away from its centre of mass, in the fingers' plane (tool
x-z), free to pivot about the closing axis (tool y) when gravity's torque beats the grip's
friction torque. Used by in-hand rotation (open the grip, let it turn under its own weight) and
by arm rotation (turn the wrist until the stick hangs and the in-finger torque vanishes).

The stick starts on a stand between the open fingers, at angle 0 along tool x; the stand takes
its weight until the hand has grasped it and lifted it by 2 mm. The fingers feel its weight as
shear and gravity's torque about the grasp as a twist of the marker field; the cameras see its
orientation in the image, and slip while it turns.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.scenes import randomise
from drivers.sim.scenes.base import Scene
from drivers.sim.scenes.grip import empty_contacts, pad_contacts, pad_view, slip_signal, step_hand, tool_rotation

GRAVITY = 9.81

PRESETS = {
    "inhand": {"mass": 0.2, "com": 0.06},  # a 20 cm bar grasped near one end
    "inhand_light": {"mass": 0.02, "com": 0.04},  # a pen
    "armrot": {"mass": 0.12, "com": 0.12},  # a stick with a heavy head, grasped by the tail
}


@dataclass
class StickScene(Scene):
    PROVIDES: ClassVar[frozenset[str] | None] = frozenset({"pivot"})  # for skills' NEEDS
    arm: SceneArm
    gripper: SceneGripper
    mass: float = 0.2  # kg
    com: float = 0.06  # m from the grasp to the centre of mass, along the stick
    width: float = 0.02  # m across the fingers
    friction: float = 0.8
    contact_radius: float = 0.004  # m, effective radius of the friction torque of each pad
    damping: float = 0.002  # N m s / rad per N of squeeze: the gel's resistance to turning in it
    min_damping: float = 0.0005  # N m s / rad
    area: float = 0.25  # share of each camera image the stick covers
    view_half: float = 0.015  # m, half the camera window

    def __post_init__(self):
        self._dt = 0.0  # s, length of the last tick (slip is motion per camera frame)
        self.angle = 0.0  # rad, stick in the tool x-z plane, from tool x towards tool z
        self._start_angle = 0.0
        self._rate = 0.0  # rad/s
        self._start_z = self.arm.pose()[2]
        self.lifted = False
        self.dropped = False

    def direction(self) -> np.ndarray:
        """Unit vector along the stick, base frame."""
        return tool_rotation(self.arm) @ np.array([math.cos(self.angle), 0.0, math.sin(self.angle)])

    def gravity_torque(self) -> float:
        """Torque (N m) gravity puts on the stick about the grasp, around tool y."""
        rot = tool_rotation(self.arm)
        r = self.com * (rot @ np.array([math.cos(self.angle), 0.0, math.sin(self.angle)]))
        weight = self.mass * GRAVITY
        torque = np.array([-r[1] * weight, r[0] * weight, 0.0])  # r x (0, 0, -weight)
        return float(torque @ rot[:, 1])

    def step(self, dt: float) -> None:
        self._dt = dt
        squeeze = step_hand(self.arm, self.gripper, None if self.dropped else self.width, dt)
        self._rate = 0.0
        if self.dropped:
            return
        if not self.lifted:
            self.lifted = squeeze > 0.0 and self.arm.pose()[2] - self._start_z > 0.002
            return
        if 2 * self.friction * squeeze < self.mass * GRAVITY:
            self.dropped = True
            return
        torque = self.gravity_torque()
        excess = abs(torque) - 2 * self.friction * squeeze * self.contact_radius
        if excess > 0.0:
            # A positive torque about tool y turns the stick from tool z towards tool x.
            damping = self.min_damping + self.damping * squeeze
            self._rate = -math.copysign(excess / damping, torque)
            self.angle += self._rate * dt

    def contacts(self):
        if self.dropped:
            return empty_contacts()
        squeeze = self.gripper.squeeze_force()
        views = (pad_view(-1.0, self.area, (0.0, 0.0), self.angle), pad_view(1.0, self.area, (0.0, 0.0), self.angle))
        if not self.lifted:
            return pad_contacts((squeeze, squeeze), np.zeros(3), 0.0, views)
        load = tool_rotation(self.arm).T @ np.array([0.0, 0.0, -self.mass * GRAVITY])
        slip = slip_signal(self._rate * self.view_half, self.area, self._dt)
        return pad_contacts((squeeze, squeeze), load, self.gravity_torque(), views, slip)

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """Dropped or never lifted off its stand; the task's own judgement is the subclasses'."""
        if self.dropped:
            return ["the stick was dropped"]
        if not self.lifted:
            return ["the stick was never lifted off its stand"]
        return []

    def turned(self) -> float:
        """Degrees the stick turned in the hand since the grasp."""
        return math.degrees(abs(self.angle - self._start_angle))

    def from_hanging(self) -> float:
        """Degrees between the stick and straight down."""
        return math.degrees(math.acos(np.clip(-self.direction()[2], -1.0, 1.0)))

    def metrics(self) -> dict:
        return {"turned in the hand (deg)": round(self.turned(), 2),
                "stick from hanging (deg)": round(self.from_hanging(), 2),
                "gravity torque (N m)": round(self.gravity_torque(), 4),
                "stick dropped": self.dropped}


class TurnScene(StickScene):
    """In-hand rotation: the task is turning the stick in the hand by the tree's target."""

    TOLERANCES: ClassVar[dict[str, float]] = {"turn_tolerance_deg": 10.0}  # how far from the target the turn may end
    TARGETS: ClassVar[dict[str, str]] = {"turn_deg": "the turn in the hand the task asks for, deg"}

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """As the stick's, and a turn further than `turn_tolerance_deg` from the tree's `turn_deg`."""
        out = super().shortfalls(tolerances)
        target = tolerances.get("turn_deg")
        if out or target is None:
            return out
        if abs(self.turned() - target) > tolerances["turn_tolerance_deg"]:
            out.append(f"the stick turned {self.turned():.1f} deg in the hand, not {target:g} +- "
                       f"{tolerances['turn_tolerance_deg']:g} deg")
        return out


class HangScene(StickScene):
    """Arm rotation: the task is turning the wrist until the stick hangs straight down."""

    TOLERANCES: ClassVar[dict[str, float]] = {"max_from_hanging_deg": 10.0}  # how far from straight down it may end

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """As the stick's, and ending further than `max_from_hanging_deg` from hanging."""
        out = super().shortfalls(tolerances)
        if not out and self.from_hanging() > tolerances["max_from_hanging_deg"]:
            out.append(f"the stick ended {self.from_hanging():.1f} deg from hanging > "
                       f"{tolerances['max_from_hanging_deg']:g} deg")
        return out


def builder(preset: str) -> Callable[..., StickScene]:
    """A scene builder for one of PRESETS (`armrot`: the stick must end hanging; the others: it
    must turn in the hand by the tree's `turn_deg`); scene args `mass` and `com` override it, and a
    randomised world draws them (`drivers.sim.scenes.randomise`)."""
    if preset == "armrot":
        def build_hang(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> HangScene:
            return HangScene(arm, gripper, friction=world.get("friction", 0.8), **_spec(preset, args, world, seed))
        return build_hang

    def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> TurnScene:
        return TurnScene(arm, gripper, friction=world.get("friction", 0.8), **_spec(preset, args, world, seed))
    return build


def _spec(preset: str, args: dict, world: dict, seed: int) -> dict:
    """The preset's mass and centre of mass, with the scene args' over them, drawn when the world
    is randomised."""
    spec = {**PRESETS[preset], **{k: args[k] for k in ("mass", "com") if k in args}}
    return randomise.params(StickScene, "stick", spec, world, seed)
