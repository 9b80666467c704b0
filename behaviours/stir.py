"""Stir: move a held stick through a substance along one of 8 predefined stirring movements
(horizontal paths around the starting point), then return to it. Marks the trial on
/task/stir_trial while stirring, so `fvtree record` can cut the training trials of StirLearn;
`classify_substance` stirs the same way."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.stirring import CYCLE, MOVEMENTS, next_trial, stir_steps


@register
class Stir(ProgramSkill):
    NAME = "stir"
    SUMMARY = "stir with the held stick along a predefined movement (StirLearn training trials)"
    PARAMS = {
        "movement": Param("str", "stirring movement, or 'cycle' for the next one in turn",
                          CYCLE, choices=(CYCLE, *MOVEMENTS)),
        "duration": Param("float", "how long to stir", 4.0, "s", min=0.5, max=60.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.STIR_TRIAL, keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING)
    NEEDS = ("bowls",)
    WRITES = (keys.STIR_TRIAL,)

    def program(self):
        trial = next_trial(self.read(keys.STIR_TRIAL))
        movement = list(MOVEMENTS)[trial % len(MOVEMENTS)] if self.p.movement == CYCLE else self.p.movement
        _, fault = yield from stir_steps(self, movement, self.p.duration, trial)
        if fault:
            return self.fail(fault)
        self.feedback_message = f"stirred trial {trial} ({movement})"
        return Status.SUCCESS
