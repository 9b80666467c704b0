"""Skill documentation and the JSON Schema of the tree language, generated from the skill
declarations so editors (yaml-language-server) check trees as they are typed."""

from __future__ import annotations

from assembly.language import PARAM_TYPES
from assembly.node_kinds import NODE, NODE_KINDS, SCHEMA_DEFS
from behaviours.base import Param
from behaviours.registry import SKILLS


def _default(p: Param):
    return None if p.required else p.default


def describe_skills() -> dict[str, dict]:
    """Every skill: summary, params (type, default, unit, range, description), keys."""
    out = {}
    for name, cls in sorted(SKILLS.items()):
        out[name] = {
            "summary": cls.SUMMARY or (cls.__doc__ or "").strip().splitlines()[0],
            "params": {k: {"type": p.type, "default": _default(p), "required": p.required, "unit": p.unit,
                           "min": p.min, "max": p.max, "choices": list(p.choices) if p.choices else None,
                           "doc": p.doc} for k, p in cls.PARAMS.items()},
            "reads": list(cls.READS),
            "writes": list(cls.WRITES),
        }
    return out


def skills_table() -> str:
    lines = []
    for name, d in describe_skills().items():
        lines.append(f"{name}: {d['summary']}")
        for pname, p in d["params"].items():
            rng = ""
            if p["min"] is not None or p["max"] is not None:
                rng = f" [{'' if p['min'] is None else p['min']}..{'' if p['max'] is None else p['max']}]"
            default = "required" if p["required"] else f"default {p['default']!r}"
            unit = f" {p['unit']}" if p["unit"] else ""
            lines.append(f"    {pname} ({p['type']}{unit}{rng}, {default}): {p['doc']}")
        if d["reads"]:
            lines.append(f"    reads:  {', '.join(d['reads'])}")
        if d["writes"]:
            lines.append(f"    writes: {', '.join(d['writes'])}")
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def tree_schema() -> dict:
    """JSON Schema (draft 2020-12) of a tree file, every node kind and skill included."""
    variants = [variant for name, kind in NODE_KINDS.items() for variant in kind.json_schema(name)]
    param_decl = {"anyOf": [{"enum": list(PARAM_TYPES)},
                            {"type": "object", "required": ["type"], "additionalProperties": False,
                             "properties": {"type": {"enum": list(PARAM_TYPES)}, "default": {},
                                            "doc": {"type": "string"}, "unit": {"type": "string"}}}]}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "fvtree behaviour tree",
        "type": "object",
        "required": ["version"],
        "additionalProperties": False,
        "properties": {
            "version": {"const": 1}, "name": {"type": "string"}, "doc": {"type": "string"},
            "cell": {"type": "object", "additionalProperties": False,
                     "properties": {"tick_hz": {"type": "number", "exclusiveMinimum": 0, "maximum": 1000},
                                    "scene": {"type": "string"},
                                    "tolerances": {"type": "object", "description": "limits of the simulated "
                                                   "run's verdict from the scene's truth (`fvtree scenes`)",
                                                   "additionalProperties": {"type": "number", "minimum": 0}}}},
            "design": {"type": "string"}, "include": {"type": "array", "items": {"type": "string"}},
            "subtrees": {"type": "object", "additionalProperties": {
                "type": "object", "required": ["root"], "additionalProperties": False,
                "properties": {"doc": {"type": "string"}, "root": NODE,
                               "params": {"type": "object", "additionalProperties": param_decl}}}},
            "root": NODE,
        },
        "$defs": {"node": {"oneOf": variants}, **SCHEMA_DEFS},
    }
