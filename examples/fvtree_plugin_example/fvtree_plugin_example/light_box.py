"""The light-box scene: fvtree's hold scene with an empty cardboard box that nobody loads (a box
stands between the open fingers, ready to be pinched or grasped). Its task is a pinch, not a hold:
the verdict asks only that the box did not fall (the hold scene's also asks that it was lifted)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.scenes import hold


class LightBoxScene(hold.HoldScene):
    """The hold scene's box, judged for a pinch."""

    TOLERANCES: ClassVar[dict[str, float]] = {}

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        return ["the box was dropped"] if self.dropped else []


def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> LightBoxScene:
    """Scene args: mass (kg, default 0.1), extra_load (N, default 0: nobody pours sand in)."""
    box = hold.build(arm, gripper, {"mass": 0.1, "extra_load": 0.0, **args}, world, seed)
    return LightBoxScene(arm, gripper, mass=box.mass, extra_load=box.extra_load, grip=box.grip)
