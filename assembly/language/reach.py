"""A tree's constant poses and offsets checked against the workspace of the cell that runs it, so a
target the safety layer would pull into the box (and the skill then fail: `skill_kit.base.move`) is
refused before the run, at the node's line. A skill param that is a vector of 6 in "m, rad" is an
absolute pose (its position must lie inside the box and the arm's reach); a vector of 3 in "m" is a
base-frame offset (no axis may be longer than the box is along it: from nowhere in the box can it
be reached, e.g. a lift of [0, 0, 50] typed in mm)."""

from __future__ import annotations

import numpy as np

from assembly.design.link.workspace import Workspace
from assembly.errors import TreeError
from assembly.language.validator import NodeSpec
from behaviours.skill_kit.base import Param
from behaviours.skill_kit.registry import SKILLS
from drivers.safety import SafetyLimits


def reach_errors(root: NodeSpec, cell: str) -> list[TreeError]:
    """Each skill param of the validated tree under `root` that is a pose outside the workspace of
    `cell` (a cell file or a packaged cell's name), or an offset longer than its box, located at
    its node."""
    workspace = Workspace.of_cell(cell)
    errors = []
    for spec in root.skills():
        for key, param in SKILLS[spec.type].PARAMS.items():
            problem = offset_or_pose_problem(param, spec.args["params"].get(key), workspace.limits)
            if problem:
                errors.append(TreeError(
                    f"param {key!r} {problem}", spec.file, spec.line, spec.path,
                    hint=f"the workspace of {workspace.source}; poses and offsets are in metres"))
    return errors


def offset_or_pose_problem(param: Param, value: object, limits: SafetyLimits) -> str | None:
    """Why a constant `value` of `param` cannot be reached inside `limits`' box, or None (also for a
    param that is neither a pose nor an offset, or a value left unset)."""
    if param.type != "vector" or not isinstance(value, (list, tuple)):
        return None
    vector = np.asarray(value, float)
    if param.length == 6 and param.unit == "m, rad":
        problem = limits.reach_problem(vector[:3])
        return None if problem is None else f"= {np.round(vector[:3], 4).tolist()} is outside the cell's workspace ({problem})"
    if param.length == 3 and param.unit == "m":
        extent = limits.workspace_max - limits.workspace_min
        too_long = [f"{'xyz'[i]} {vector[i]:g} m > the box's {extent[i]:g} m" for i in range(3) if abs(vector[i]) > extent[i]]
        return None if not too_long else (f"= {vector.tolist()} cannot stay inside the cell's workspace from anywhere "
                                           f"in it ({', '.join(too_long)})")
    return None

