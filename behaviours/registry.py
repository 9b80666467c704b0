"""Maps YAML skill names to Skill classes."""

from __future__ import annotations

from behaviours.base import Skill

SKILLS: dict[str, type[Skill]] = {}


def register(cls: type[Skill]) -> type[Skill]:
    """Class decorator: make a Skill available to trees under `cls.NAME`."""
    if not cls.NAME:
        raise TypeError(f"{cls.__name__} has no NAME")
    if cls.NAME in SKILLS and SKILLS[cls.NAME] is not cls:
        raise TypeError(f"skill name {cls.NAME!r} is already taken by {SKILLS[cls.NAME].__name__}")
    SKILLS[cls.NAME] = cls
    return cls

