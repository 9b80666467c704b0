"""The light-box scene: fvtree's hold scene with an empty cardboard box that nobody loads (a box
stands between the open fingers, ready to be pinched or grasped)."""

from __future__ import annotations

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.scenes import hold


def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> hold.HoldScene:
    """Scene args: mass (kg, default 0.1), extra_load (N, default 0: nobody pours sand in)."""
    return hold.build(arm, gripper, {"mass": 0.1, "extra_load": 0.0, **args}, world, seed)
