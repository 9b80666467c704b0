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
        return ["the stick was dropped"] if self.dropped else []

    def metrics(self) -> dict:
        hanging = math.degrees(math.acos(np.clip(-self.direction()[2], -1.0, 1.0)))
        return {"turned in the hand (deg)": round(math.degrees(abs(self.angle - self._start_angle)), 2),
                "stick from hanging (deg)": round(hanging, 2),
                "gravity torque (N m)": round(self.gravity_torque(), 4),
                "stick dropped": self.dropped}


def builder(preset: str) -> Callable[..., StickScene]:
    """A scene builder for one of PRESETS; scene args `mass` and `com` override it."""
    def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> StickScene:
        spec = {**PRESETS[preset], **{k: args[k] for k in ("mass", "com") if k in args}}
        spec = randomise.params(StickScene, "stick", spec, world, seed)
        return StickScene(arm, gripper, friction=world.get("friction", 0.8), **spec)
    return build
