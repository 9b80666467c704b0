"""Which skills a simulated scene can host: a skill declares what the world must have for it to
work (`Skill.NEEDS`: a surface below the tool, plates, a person, ...) and a scene what it has
(`Scene.PROVIDES`), so a tree that asks for a skill its scene lacks the thing for (a descent until
contact in the handover scene, which has no table) is refused before it runs, at the node's line,
instead of "finding" contact in the air. A scene that declares nothing (a plug-in's) is not checked."""

from __future__ import annotations

import typing
from collections.abc import Callable

from assembly.errors import TreeError
from assembly.language.validator import NodeSpec
from behaviours.skill_kit.base import WORLD_NEEDS
from behaviours.skill_kit.registry import SKILLS


def provides(build: Callable) -> frozenset[str] | None:
    """What the scene a builder returns has for skills (None: not declared)."""
    try:
        scene = typing.get_type_hints(build).get("return")
    except (NameError, TypeError):
        return None
    return getattr(scene, "PROVIDES", None)


def supported_skills(has: frozenset[str] | None) -> list[str]:
    """The registered skills a scene that has `has` can host (all of them when undeclared)."""
    return sorted(name for name, cls in SKILLS.items() if has is None or set(cls.NEEDS) <= has)


def scene_errors(root: NodeSpec, scene: str) -> list[TreeError]:
    """Each skill node under `root` that needs something simulated scene `scene` lacks, with the
    scenes that have it; none when the scene is unknown (reported elsewhere) or undeclared."""
    from drivers.sim.scenes import SCENES  # the simulators are large: imported when a tree names a scene

    build = SCENES.get(scene)
    has = provides(build) if build is not None else None
    if has is None:
        return []
    errors = []
    for spec in root.skills():
        for need in SKILLS[spec.type].NEEDS:
            if need not in has:
                others = sorted(name for name, b in SCENES.items() if need in (provides(b) or ()))
                errors.append(TreeError(
                    f"skill {spec.type!r} needs {WORLD_NEEDS.get(need, need)}, which scene {scene!r} does not have "
                    f"(it has: {', '.join(sorted(has)) or 'nothing of the kind'})", spec.file, spec.line, spec.path,
                    hint=f"scenes with {need}: {', '.join(others) or 'none'}; `fvtree scenes` lists what each supports"))
    return errors

