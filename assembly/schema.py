"""Skill documentation and the JSON Schema of the tree language, generated from the skill
declarations so editors (yaml-language-server) check trees as they are typed."""

from __future__ import annotations

from typing import Any

from assembly.conditions import ALL_OPS
from assembly.language import COMMON_FIELDS, KINDS, PARAM_TYPES, POLICIES, STATUSES
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


def _param_schema(p: Param) -> dict:
    if p.type == "vector":
        s: dict[str, Any] = {"type": "array", "items": {"type": "number"}}
        if p.length:
            s["minItems"] = s["maxItems"] = p.length
        items = s["items"]
    else:
        s = {"type": {"float": "number", "int": "integer", "bool": "boolean", "str": "string"}[p.type]}
        items = s
    if p.min is not None:
        items["minimum"] = p.min
    if p.max is not None:
        items["maximum"] = p.max
    if p.choices:
        s["enum"] = list(p.choices)
    s["description"] = p.doc + (f" [{p.unit}]" if p.unit else "")
    if not p.required and p.default is not None:
        s["default"] = p.default
    return s


def _skill_node(name: str, cls) -> dict:
    props = {"skill": {"const": name}, "name": {"type": "string"}, "doc": {"type": "string"},
             "params": {"type": "object", "additionalProperties": False,
                        "properties": {k: {"anyOf": [_param_schema(p), {"type": "string", "pattern": r"^\$"}]}
                                       for k, p in cls.PARAMS.items()}}}
    return {"type": "object", "required": ["skill"], "additionalProperties": False, "properties": props,
            "description": cls.SUMMARY}


def tree_schema() -> dict:
    node = {"$ref": "#/$defs/node"}
    field_schema = {
        "memory": {"type": "boolean"}, "children": {"type": "array", "items": node, "minItems": 1},
        "child": node, "policy": {"enum": list(POLICIES)}, "synchronise": {"type": "boolean"},
        "selected": {"type": "array", "items": {"type": "string"}},
        "attempts": {"type": "integer", "minimum": 1}, "times": {"type": "integer", "minimum": -1},
        "seconds": {"type": "number", "exclusiveMinimum": 0},
        "map": {"type": "object", "propertyNames": {"enum": list(STATUSES)},
                "additionalProperties": {"enum": list(STATUSES)}},
        "while": {"$ref": "#/$defs/condition"}, "elements": {"type": "array", "items": {"type": "string"}},
        "key": {"type": "string", "pattern": "^/"}, "op": {"enum": list(ALL_OPS)}, "value": {},
        "params": {"type": "object"}, "name": {"type": "string"}, "doc": {"type": "string"},
    }
    variants = []
    for kind, spec in KINDS.items():
        if kind == "skill":
            continue
        fields = spec["required"] | spec["optional"] | COMMON_FIELDS
        props = {kind: {"type": "string"}, **{f: field_schema[f] for f in fields}}
        variants.append({"type": "object", "required": [kind, *sorted(spec["required"])],
                         "additionalProperties": False, "properties": props})
    variants += [_skill_node(n, c) for n, c in sorted(SKILLS.items())]
    param_decl = {"anyOf": [{"enum": list(PARAM_TYPES)},
                            {"type": "object", "required": ["type"],
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
                                    "scene": {"type": "string"}}},
            "design": {"type": "string"}, "include": {"type": "array", "items": {"type": "string"}},
            "subtrees": {"type": "object", "additionalProperties": {
                "type": "object", "required": ["root"], "additionalProperties": False,
                "properties": {"doc": {"type": "string"}, "root": node,
                               "params": {"type": "object", "additionalProperties": param_decl}}}},
            "root": node,
        },
        "$defs": {
            "node": {"oneOf": variants},
            "condition": {"type": "object", "required": ["key", "op"], "additionalProperties": False,
                          "properties": {"key": field_schema["key"], "op": field_schema["op"], "value": {}}},
        },
    }
