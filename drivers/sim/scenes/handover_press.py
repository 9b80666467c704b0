"""The handover-and-press scene, composed of two others: a person hands the robot a stick (the
handover scene's person, who never takes it back) above an electronic scale (the press scene's);
from the moment the robot holds it, the press scene carries on with the stick in the fingers and
the scale `scale_gap` below its tip. "Receive by handover, press on the scale, release" runs here,
and its verdict judges both parts: the stick taken from the person, the scale's force against the
tree's target, the stick left resting on the scale."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.scenes import randomise
from drivers.sim.scenes.base import Scene
from drivers.sim.scenes.grip import Grip
from drivers.sim.scenes.handover import HandoverScene
from drivers.sim.scenes.press import PressScene


@dataclass
class HandoverPressScene(Scene):
    arm: SceneArm
    gripper: SceneGripper
    handover: HandoverScene
    friction: float = 0.8
    seed: int = 0
    scale: dict[str, float] = field(default_factory=dict)  # the press scene's contact_stiffness, scale_noise
    press: PressScene | None = field(default=None, init=False)  # made once the robot holds the stick

    PROVIDES: ClassVar[frozenset[str] | None] = frozenset({"giver", "surface"})  # the handover's and the press's
    TOLERANCES: ClassVar[dict[str, float]] = {**HandoverScene.TOLERANCES, **PressScene.TOLERANCES}
    TARGETS: ClassVar[dict[str, str]] = dict(PressScene.TARGETS)

    def step(self, dt: float) -> None:
        if self.press is not None:
            self.press.step(dt)
            return
        self.handover.step(dt)
        if self.handover.phase == "robot":  # the person let go: the stick is the robot's, above the scale
            self.press = PressScene(self.arm, self.gripper, mass=self.handover.mass, width=self.handover.width,
                                    seed=self.seed, grip=Grip(friction=self.friction), **self.scale)
            self.press.held = True

    def contacts(self):
        return self.press.contacts() if self.press is not None else self.handover.contacts()

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """The handover's (the stick never taken, dropped), then the press scene's on the stick."""
        if self.press is None:
            return self.handover.shortfalls(tolerances)
        return self.press.shortfalls(tolerances)

    def metrics(self) -> dict:
        if self.press is None:
            return self.handover.metrics()
        return {"stick": "taken from the person", **self.press.metrics()}

    def labels(self) -> dict:
        return self.press.labels() if self.press is not None else {}

    def label_info(self) -> dict:
        return self.press.label_info() if self.press is not None else {}


def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> HandoverPressScene:
    """Scene args: mass (kg) of the stick (the press scene's, 0.05). Randomised, the person is drawn as
    the handover scene's and the scale (its stiffness under the stick, its noise) as the press scene's."""
    friction = world.get("friction", 0.8)
    given = {"mass": args.get("mass", 0.05)}  # the person's part drawn as the handover scene's when randomised
    handover = HandoverScene(arm, gripper, width=0.02, give_after=-1.0,
                             **randomise.params(HandoverScene, "handover", given, world, seed),
                             grip=Grip(friction=friction))
    scale = randomise.params(PressScene, "handover_press.scale", {}, world, seed)
    return HandoverPressScene(arm, gripper, handover, friction=friction, seed=seed, scale=scale)
