"""Skills and scenes from other installed packages, through Python entry points:

    [project.entry-points."fvtree.skills"]
    pinch = "my_package.pinch:Pinch"          # a Skill class whose NAME is the entry point's name
    [project.entry-points."fvtree.scenes"]
    light_box = "my_package.light_box:build"  # a builder (arm, gripper, args, world, seed) -> World

They are loaded once, before a tree is validated or the skills and scenes are listed, into the
same tables as this project's own (`behaviours.skill_kit.registry.SKILLS`, `drivers.sim.scenes.SCENES`), each
with its package. A name another package has taken, or an entry point that does not load, is a
PluginError naming the package and the entry point (exit code 2). Loading sits here, in the top
package, because skills (behaviours) and scenes (drivers) may not import each other's packages.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from importlib.metadata import EntryPoint, entry_points
from typing import Any

from behaviours.skill_kit.base import Skill
from behaviours.skill_kit.registry import SKILL_PACKAGES, SKILLS, register
from fvfiles.errors import FvtreeError

SKILL_GROUP = "fvtree.skills"
SCENE_GROUP = "fvtree.scenes"

_loaded = False


class PluginError(FvtreeError):
    """A plug-in entry point that cannot be loaded, names the wrong thing, or clashes with a name taken."""


def _package(ep: EntryPoint) -> str:
    return ep.dist.name if ep.dist is not None else ep.value.partition(":")[0]


def _load(ep: EntryPoint, group: str, fits: Callable[[object], bool], what: str) -> Any:
    """The object the entry point names (foreign code, so typed only by what `fits` checked)."""
    where = f"plug-in {_package(ep)}: {group} entry point {ep.name} = {ep.value}"
    try:
        obj = ep.load()
    except Exception as exc:  # any failure of foreign code is reported the same way
        raise PluginError(f"{where} does not load: {type(exc).__name__}: {exc}",
                          hint="fix or uninstall the plug-in package") from exc
    if not fits(obj):
        raise PluginError(f"{where} must name {what}")
    return obj


def _skill_named(name: str) -> Callable[[object], bool]:
    """Whether an object is a Skill class whose NAME is `name`."""
    return lambda o: isinstance(o, type) and issubclass(o, Skill) and o.NAME == name


def _clash(kind: str, name: str, ep: EntryPoint, taken_by: str) -> PluginError:
    return PluginError(f"plug-in {_package(ep)}: {kind} {name!r} clashes with the {kind} of that name from "
                       f"package {taken_by}", hint=f"rename the {kind} in {_package(ep)}")


def add_skills(found: Iterable[EntryPoint]) -> list[str]:
    """Register the skills the entry points name; returns their names."""
    names = []
    for ep in found:
        cls = _load(ep, SKILL_GROUP, _skill_named(ep.name), f"a Skill class whose NAME is {ep.name!r}")
        if SKILLS.get(ep.name, cls) is not cls:
            raise _clash("skill", ep.name, ep, SKILL_PACKAGES[ep.name])
        register(cls, _package(ep))
        names.append(ep.name)
    return names


def add_scenes(found: Iterable[EntryPoint]) -> list[str]:
    """Add the scenes the entry points name to SCENES; returns their names."""
    found = list(found)
    if not found:  # the simulators load only when a plug-in adds a scene (not for `fvtree validate`)
        return []
    from drivers.sim.scenes import SCENE_PACKAGES, SCENES  # the simulators are large: imported when needed

    names = []
    for ep in found:
        build = _load(ep, SCENE_GROUP, callable, "a scene builder (arm, gripper, args, world, seed) -> World")
        if SCENES.get(ep.name, build) is not build:
            raise _clash("scene", ep.name, ep, SCENE_PACKAGES[ep.name])
        SCENES[ep.name], SCENE_PACKAGES[ep.name] = build, _package(ep)
        names.append(ep.name)
    return names


def load_plugins() -> None:
    """Load every installed plug-in's skills and scenes, once."""
    global _loaded
    if not _loaded:
        found = entry_points()  # one scan of the installed packages for both groups
        add_skills(found.select(group=SKILL_GROUP))
        add_scenes(found.select(group=SCENE_GROUP))
        _loaded = True
