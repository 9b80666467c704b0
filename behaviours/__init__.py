"""One py_trees behaviour per tactile skill, registered by its YAML name. Skills of other installed
packages register through entry points (group `fvtree.skills`, loaded by `assembly.language.plugins`)."""

from fvfiles.user_cache import use_user_cache_for_numba

use_user_cache_for_numba()  # before a module of this package imports numba (see fvfiles/user_cache.py)

from behaviours import (  # noqa: F401  (importing registers the skills)
    approach_plate,
    arm_rot,
    classify_substance,
    descend_until_contact,
    estop_guard,
    find_max_load,
    force_track,
    gentle_grasp,
    handover,
    hold,
    in_hand_man,
    in_hand_rot,
    locate_element,
    move_to,
    object_track,
    place_element,
    press_with_force,
    release,
    rotate_element,
    stir,
    vis_scan,
)
from behaviours.skill_kit.base import Param, ProgramSkill, Skill
from behaviours.skill_kit.registry import SKILLS, register

__all__ = ["SKILLS", "Param", "ProgramSkill", "Skill", "register"]
