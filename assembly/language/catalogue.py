"""The catalogue of what a tree can use, for people and tools: every skill (package, summary,
params with type, default, unit and range, blackboard keys) and every simulated scene (what it
simulates, its params, the tolerances of its verdict, the demo trees that use it), plug-ins
included: `fvtree skills` and `fvtree scenes`."""

from __future__ import annotations

import inspect
import re
import sys
import typing
from pathlib import Path

from assembly.language.plugins import load_plugins
from behaviours.skill_kit.base import Param
from behaviours.skill_kit.registry import PROJECT, SKILL_PACKAGES, SKILLS
from fvfiles.errors import FvtreeError
from fvfiles.yaml_source import load_file

DEMO_TREES = Path(__file__).resolve().parents[2] / "trees"


def _default(p: Param):
    return None if p.required else p.default


def describe_skills() -> dict[str, dict]:
    """Every skill: package, summary, params (type, default, unit, range, the device range of the cell it
    must lie in, description), keys."""
    load_plugins()
    out = {}
    for name, cls in sorted(SKILLS.items()):
        out[name] = {
            "package": SKILL_PACKAGES.get(name, PROJECT),
            "summary": cls.SUMMARY or (cls.__doc__ or "").strip().splitlines()[0],
            "params": {k: {"type": p.type, "default": _default(p), "required": p.required, "unit": p.unit,
                           "min": p.min, "max": p.max, "choices": list(p.choices) if p.choices else None,
                           "device": p.device or None, "doc": p.doc} for k, p in cls.PARAMS.items()},
            "reads": list(cls.READS),
            "writes": list(cls.WRITES),
        }
    return out


def skills_table() -> str:
    lines = []
    for name, d in describe_skills().items():
        lines.append(f"{name}: {d['summary']}" + (f" [plug-in {d['package']}]" if d["package"] != PROJECT else ""))
        for pname, p in d["params"].items():
            rng = ""
            if p["min"] is not None or p["max"] is not None:
                rng = f" [{'' if p['min'] is None else p['min']}..{'' if p['max'] is None else p['max']}]"
            default = "required" if p["required"] else f"default {p['default']!r}"
            unit = f" {p['unit']}" if p["unit"] else ""
            device = f", within the cell's {p['device']}" if p["device"] else ""
            lines.append(f"    {pname} ({p['type']}{unit}{rng}, {default}{device}): {p['doc']}")
        if d["reads"]:
            lines.append(f"    reads:  {', '.join(d['reads'])}")
        if d["writes"]:
            lines.append(f"    writes: {', '.join(d['writes'])}")
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def _first_paragraph(text: str | None) -> str:
    return " ".join((text or "").strip().split("\n\n")[0].split())


def _first_sentence(text: str | None) -> str:
    return re.split(r"(?<=\.)\s", _first_paragraph(text), maxsplit=1)[0]


def _scene_params(build) -> str:
    """What a scene builder's docstring says of its args (a builder made by a factory: the
    factory's docstring, with the values it was made with)."""
    doc = inspect.getdoc(build)
    made_with = ""
    if doc is None and ".<locals>." in build.__qualname__:
        factory = getattr(sys.modules[build.__module__], build.__qualname__.split(".<locals>.")[0], None)
        doc = inspect.getdoc(factory)
        made_with = ", ".join(f"{k}={v!r}" for k, v in inspect.getclosurevars(build).nonlocals.items())
    text = _first_paragraph(doc)
    return f"{text} ({made_with})" if made_with else text


def _tolerances(build) -> dict[str, float]:
    """The tolerances of the verdict the scene a builder returns knows, with their defaults."""
    try:
        scene = typing.get_type_hints(build).get("return")
    except (NameError, TypeError):
        return {}
    return dict(getattr(scene, "TOLERANCES", {}) or {})


def _targets(build) -> dict[str, str]:
    """The targets of the verdict only a tree can set (name -> what it is), for the scene a builder returns."""
    try:
        scene = typing.get_type_hints(build).get("return")
    except (NameError, TypeError):
        return {}
    return dict(getattr(scene, "TARGETS", {}) or {})


def _provides(build) -> list[str] | None:
    """What the scene a builder returns has for skills (None: not declared)."""
    from assembly.language.affordances import provides

    has = provides(build)
    return None if has is None else sorted(has)


def _skills(build) -> list[str]:
    """The skills the scene a builder returns can host."""
    from assembly.language.affordances import provides, supported_skills

    return supported_skills(provides(build))


def _demo_trees() -> dict[str, list[str]]:
    """scene -> the shipped trees (trees/*.yaml) that ask for it."""
    out: dict[str, list[str]] = {}
    for path in sorted(DEMO_TREES.glob("*.yaml")):
        try:
            doc = load_file(path)
        except FvtreeError:
            continue
        cell = doc.get("cell") if isinstance(doc, dict) else None
        scene = cell.get("scene", "assembly") if isinstance(cell, dict) else "assembly"
        out.setdefault(str(scene), []).append(f"trees/{path.name}")
    return out


def describe_scenes() -> dict[str, dict]:
    """Every simulated scene: its package, what it simulates, its params, the tolerances of its
    verdict and the demo trees that use it."""
    from drivers.sim.scenes import SCENE_PACKAGES, SCENES  # the simulators are large: imported when needed

    load_plugins()
    trees = _demo_trees()
    return {name: {"package": SCENE_PACKAGES.get(name, PROJECT),
                   "simulates": _first_sentence(sys.modules[build.__module__].__doc__),
                   "params": _scene_params(build), "tolerances": _tolerances(build),
                   "targets": _targets(build), "provides": _provides(build), "skills": _skills(build), "trees": trees.get(name, []),
                   "randomised": _randomised(name)}
            for name, build in sorted(SCENES.items())}


def _randomised(scene: str) -> dict[str, str]:
    """What a scene draws per seed with `world: {randomise: true}`: {group.param: 'range: why'}."""
    from drivers.sim.scenes import randomise

    return {f"{group}.{name}": text for group in randomise.groups_of(scene)
            for name, text in randomise.describe(group).items()}


def randomised_everywhere() -> dict[str, str]:
    """What every simulated scene draws per seed when randomised (sensor, force sensor, world)."""
    from drivers.sim.scenes import randomise

    return {f"{group}.{name}": text for group in randomise.SHARED_GROUPS
            for name, text in randomise.describe(group).items()}


def scenes_table() -> str:
    lines = []
    for name, d in describe_scenes().items():
        lines.append(f"{name}: {d['simulates']}" + (f" [plug-in {d['package']}]" if d["package"] != PROJECT else ""))
        lines.append(f"    params: {d['params'] or 'none'}")
        if d["tolerances"]:
            lines.append("    tolerances: " + ", ".join(f"{k} (default {v:g})" for k, v in d["tolerances"].items()))
        if d["provides"] is not None:
            lines.append(f"    has: {', '.join(d['provides']) or 'nothing skills need beyond its object'}")
            lines.append(f"    skills: {', '.join(d['skills'])}")
        if d["targets"]:
            lines.append("    targets (set by the tree): " + ", ".join(f"{k} ({v})" for k, v in d["targets"].items()))
        lines.append(f"    demo trees: {', '.join(d['trees']) or 'none'}")
        lines += [f"    randomised {name}: {text}" for name, text in d.get("randomised", {}).items()]
        lines.append("")
    lines.append("every scene, with `world: {randomise: true}` in the cell file (drawn per seed):")
    lines += [f"    {name}: {text}" for name, text in randomised_everywhere().items()]
    return "\n".join(lines).rstrip() + "\n"
