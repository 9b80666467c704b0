"""The JSON Schema of the tree language, generated from the tables of a tree file's fields, the
node kinds, the skill declarations and the scenes table (plug-ins included) so editors
(yaml-language-server) check trees as they are typed."""

from __future__ import annotations

from assembly.language.blackboard import blackboard_schema, field_paths
from assembly.language.catalogue import describe_scenes
from assembly.language.fields import TOP_FIELDS, object_schema
from assembly.language.kinds import CONDITION_FIELDS, NODE_KINDS, SCHEMA_DEFS
from assembly.language.plugins import load_plugins
from behaviours.skill_kit.registry import PROJECT, SKILL_PACKAGES


def tree_schema() -> dict:
    """JSON Schema (draft 2020-12) of a tree file, every node kind and skill included."""
    load_plugins()
    variants = [variant for name, kind in NODE_KINDS.items() for variant in kind.json_schema(name)]
    for variant in variants:  # a plug-in's skill says which package it comes from
        skill = variant["properties"].get("skill", {}).get("const")
        if SKILL_PACKAGES.get(skill, PROJECT) != PROJECT:
            variant["description"] += f" [plug-in {SKILL_PACKAGES[skill]}]"
    top = object_schema(TOP_FIELDS)
    scenes = describe_scenes()  # the scene's names and what they simulate, beyond its table entry
    top["properties"]["cell"]["properties"]["scene"] |= {
        "enum": sorted(scenes), "description": "the simulated scene (`fvtree scenes`): " + "; ".join(
            f"{n}: {d['simulates']}" for n, d in sorted(scenes.items()))}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "fvtree behaviour tree",
        **top,
        "$defs": {"node": {"oneOf": variants}, **condition_defs(), "blackboard": blackboard_schema()},
    }


def condition_defs() -> dict:
    """The condition's schema, its `key` offering every blackboard key and field path (editors
    complete from `examples`; an index such as `[1]` may follow a list)."""
    key = {**CONDITION_FIELDS["key"], "examples": field_paths(),
           "description": "a blackboard key, then fields and indices: see $defs.blackboard"}
    return {"condition": {**SCHEMA_DEFS["condition"], "properties": {**CONDITION_FIELDS, "key": key}}}
