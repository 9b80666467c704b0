"""The JSON Schema of the tree language, generated from the node kinds, the skill declarations
and the scenes table (plug-ins included) so editors (yaml-language-server) check trees as they are
typed."""

from __future__ import annotations

from assembly.language.catalogue import describe_scenes
from assembly.language.kinds import NODE, NODE_KINDS, SCHEMA_DEFS
from assembly.language.plugins import load_plugins
from assembly.language.validator import PARAM_TYPES
from behaviours.skill_kit.registry import PROJECT, SKILL_PACKAGES


def tree_schema() -> dict:
    """JSON Schema (draft 2020-12) of a tree file, every node kind and skill included."""
    load_plugins()
    variants = [variant for name, kind in NODE_KINDS.items() for variant in kind.json_schema(name)]
    for variant in variants:  # a plug-in's skill says which package it comes from
        skill = variant["properties"].get("skill", {}).get("const")
        if SKILL_PACKAGES.get(skill, PROJECT) != PROJECT:
            variant["description"] += f" [plug-in {SKILL_PACKAGES[skill]}]"
    scenes = describe_scenes()
    scene = {"enum": sorted(scenes), "description": "the simulated scene (`fvtree scenes`): " + "; ".join(
        f"{n}: {d['simulates']}" for n, d in sorted(scenes.items()))}
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
                                    "scene": scene,
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
