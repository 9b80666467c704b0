"""The fields of a tree file, one table entry each: the top level, the `cell:` settings and a
subtree's fields, each with the JSON Schema of its value, a one-line doc and where it is required.

The reader checks a file against these tables (unknown fields, missing ones, values) and
`tree_schema()` publishes them, so the loader and an editor using the schema agree on what a tree
file may hold. What a schema cannot say stays as code, named by the field's `checked_by`: the node
kinds (the validator), a param's default against its type, and the simulator's scene names.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from assembly.language.kinds import NODE
from assembly.language.validator import PARAM_TYPES

OPTIONAL = "optional"
ALWAYS = "always"  # in every file that holds the mapping (an included file too)
TREE_FILE = "tree file"  # in the tree file loaded; an included file may leave it out


@dataclass(frozen=True)
class Field:
    """One field of a mapping in a tree file. `schema` is the JSON Schema of the value itself; a
    mapping value's own fields (`fields`) or named entries (`entries`) are fields in turn, so each
    is checked at its own line. `checked_by` names the code that checks what the schema cannot
    (the reader then checks only `schema`, and leaves the value's insides to that code)."""

    schema: dict
    doc: str
    required: str = OPTIONAL
    fields: Mapping[str, Field] | None = None
    entries: Field | None = None
    checked_by: str = ""


def required(table: Mapping[str, Field], tree_file: bool) -> list[str]:
    """The fields of `table` a mapping must have, in the tree file loaded or in an included file."""
    return [key for key, f in table.items() if f.required == ALWAYS or (tree_file and f.required == TREE_FILE)]


def json_schema(field: Field) -> dict:
    """The whole JSON Schema of a field's value, its fields and entries included."""
    out = {**field.schema, "description": field.doc}
    if field.fields is not None:
        out = {**object_schema(field.fields), **out}
    if field.entries is not None:
        out["additionalProperties"] = json_schema(field.entries)
    return out


def object_schema(table: Mapping[str, Field]) -> dict:
    """JSON Schema of a mapping with exactly the fields of `table` (required: those in every file)."""
    out = {"type": "object", "additionalProperties": False,
           "properties": {key: json_schema(f) for key, f in table.items()}}
    always = required(table, tree_file=False)
    return {**out, "required": always} if always else out


PARAM_DECLARATION = Field(
    {"anyOf": [{"enum": list(PARAM_TYPES)},
               {"type": "object", "required": ["type"], "additionalProperties": False,
                "properties": {"type": {"enum": list(PARAM_TYPES)}, "default": {}, "doc": {"type": "string"},
                               "unit": {"type": "string"}}}]},
    "a param's type, or {type, default, doc, unit}")

# A "null" type: an empty value is taken as none (cell, include, subtrees, params), as the reader always has.
CELL_FIELDS: dict[str, Field] = {
    "tick_hz": Field({"type": "number", "exclusiveMinimum": 0, "maximum": 1000, "default": 30},
                     "ticks per second on the cell clock"),
    "scene": Field({"type": "string", "default": "assembly"}, "the simulated scene (`fvtree scenes`)",
                   checked_by="the reader, against the simulator's scenes"),
    "tolerances": Field({"type": "object"}, "limits of the simulated run's verdict from the scene's truth, "
                        "by the names the scene knows (`fvtree scenes`; checked when the tree runs)",
                        entries=Field({"type": "number", "minimum": 0}, "the limit of one measure of the verdict")),
}

SUBTREE_FIELDS: dict[str, Field] = {
    "doc": Field({"type": "string"}, "what the subtree does"),
    "params": Field({"type": ["object", "null"]}, "the subtree's typed params: {name: type} or "
                    "{name: {type, default, doc, unit}}", entries=PARAM_DECLARATION,
                    checked_by="validator.subtree_params: a default must fit its type"),
    "root": Field(NODE, "the subtree's root node", ALWAYS, checked_by="the validator, by node kind"),
}

TOP_FIELDS: dict[str, Field] = {
    "version": Field({"const": 1}, "the version of the tree language", ALWAYS),
    "name": Field({"type": "string", "minLength": 1}, "the tree's name, in logs and run summaries; "
                  "required in the tree file, not in an included one", TREE_FILE),
    "doc": Field({"type": "string"}, "what the tree does"),
    "cell": Field({"type": ["object", "null"]}, "the cell the tree runs on: tick rate, simulated scene, "
                  "tolerances", fields=CELL_FIELDS),
    "design": Field({"type": "string", "minLength": 1}, "the design model (networkx node-link JSON), "
                    "relative to this file"),
    "include": Field({"type": ["array", "null"], "items": {"type": "string", "minLength": 1}},
                     "files whose `subtrees:` join this file's, relative to it"),
    "subtrees": Field({"type": ["object", "null"]}, "named subtrees: {name: {doc, params, root}}",
                      entries=Field({"type": "object"}, "a subtree", fields=SUBTREE_FIELDS)),
    "root": Field(NODE, "the root node; required in the tree file, not in an included one", TREE_FILE,
                  checked_by="the validator, by node kind"),
}
