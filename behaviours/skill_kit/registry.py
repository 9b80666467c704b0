"""Maps YAML skill names to Skill classes, with the package each comes from: this project's
skills register when `behaviours` imports their modules, plug-in packages' skills when
`assembly.language.plugins` loads their entry points."""

from __future__ import annotations

from behaviours.skill_kit.base import Skill

PROJECT = "fvtree"  # the package of the skills in this repository

SKILLS: dict[str, type[Skill]] = {}
SKILL_PACKAGES: dict[str, str] = {}  # skill name -> the package providing it


def register(cls: type[Skill], package: str = PROJECT) -> type[Skill]:
    """Class decorator: make a Skill available to trees under `cls.NAME`."""
    if not cls.NAME:
        raise TypeError(f"{cls.__name__} has no NAME")
    if cls.NAME in SKILLS and SKILLS[cls.NAME] is not cls:
        raise TypeError(f"skill name {cls.NAME!r} is already taken by {SKILLS[cls.NAME].__name__} "
                        f"of package {SKILL_PACKAGES[cls.NAME]}")
    SKILLS[cls.NAME] = cls
    SKILL_PACKAGES[cls.NAME] = package
    return cls
