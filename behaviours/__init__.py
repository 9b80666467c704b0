"""One py_trees behaviour per tactile skill, registered by its YAML name."""

from behaviours import (  # noqa: F401  (importing registers the skills)
    approach_plate,
    descend_until_contact,
    estop_guard,
    find_max_load,
    gentle_grasp,
    locate_element,
    move_to,
    place_element,
    rotate_element,
    vis_scan,
    hold,
    force_track,
    object_track,
    handover,
    arm_rot,
    in_hand_rot,
    in_hand_man,
    press_with_force,
    stir,
    classify_substance,
)
from behaviours.base import Param, ProgramSkill, Skill
from behaviours.registry import SKILLS, register

__all__ = ["Param", "ProgramSkill", "SKILLS", "Skill", "register"]
