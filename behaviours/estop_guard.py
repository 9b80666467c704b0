"""E-stop guard: first child of a memoryless root selector, it takes priority when the e-stop
is requested (the running branch is halted) and holds the arm and gripper still."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Skill
from behaviours.skill_kit.registry import register


@register
class EstopGuard(Skill):
    NAME = "estop_guard"
    SUMMARY = "RUNNING and holding the cell still while the e-stop is set; FAILURE otherwise"
    READS = (keys.ESTOP,)
    RUNS_UNTIL_HALTED = True  # RUNNING for as long as the e-stop stays set

    def update(self) -> Status:
        if not self.read(keys.ESTOP, False):
            return Status.FAILURE
        self.cell.arm.stop()
        self.cell.gripper.stop()
        self.feedback_message = "e-stop active: arm and gripper stopped"
        return Status.RUNNING
