"""What the orchestrator writes to py_trees' process-global blackboard: the perception stage
before every tick, and a clean slate before every run."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import py_trees
from py_trees.blackboard import Blackboard

from behaviours.skill_kit import keys
from drivers.cell import Cell
from drivers.protocols import PerceptionSource


def publish_perception(cell: Cell, states: Mapping[str, Any] | None = None) -> None:
    """The perception stage: write this tick's tactile, robot and gripper state and the e-stop.

    It is the only writer of these keys, so it stores them directly (py_trees' checked
    `Blackboard.set` would cost more than the rest of the stage); skills read them through
    clients registered with READ access.
    """
    states = cell.sense() if states is None else states
    arm, gripper = cell.arm, cell.gripper
    Blackboard.storage.update({
        keys.FV_LEFT: states["left"],
        keys.FV_RIGHT: states["right"],
        keys.ROBOT_POSE: arm.pose(),
        keys.ROBOT_WRENCH: arm.tcp_wrench(),
        keys.ROBOT_FAULT: arm.fault(),
        keys.ROBOT_MOVING: arm.is_moving(),
        keys.GRIPPER_WIDTH: gripper.width(),
        keys.GRIPPER_OBJECT: gripper.object_detected(),
        keys.GRIPPER_FAULT: gripper.fault(),
        keys.GRIPPER_MOVING: gripper.is_moving(),
        keys.ESTOP: cell.estop,
    })


class PerceptionStage:
    """Pre-tick handler: publish the perception of `sense` (the cell's own by default)."""

    def __init__(self, cell: Cell, sense: PerceptionSource | None = None):
        self.cell = cell
        self.sense = sense or cell.sense

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        publish_perception(self.cell, self.sense())


def clear_blackboard() -> None:
    """Forget every key and client (the blackboard is process-global in py_trees)."""
    Blackboard.clear()
