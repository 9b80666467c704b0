"""Maps YAML skill names to Skill classes."""

from __future__ import annotations

import difflib

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


def lookup(name: str) -> type[Skill]:
    """The Skill class registered as `name`; KeyError with a did-you-mean hint otherwise."""
    try:
        return SKILLS[name]
    except KeyError:
        close = difflib.get_close_matches(name, SKILLS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise KeyError(f"unknown skill {name!r}{hint}") from None
