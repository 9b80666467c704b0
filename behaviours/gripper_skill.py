"""Base of program skills that move the gripper: halting one stops the gripper as well as the arm."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.base import ProgramSkill


class GripperProgramSkill(ProgramSkill):
    """A ProgramSkill whose `terminate` also stops the gripper when the skill is interrupted."""

    def terminate(self, new_status: Status) -> None:
        super().terminate(new_status)
        if new_status == Status.INVALID and self.cell is not None:
            self.cell.gripper.stop()
