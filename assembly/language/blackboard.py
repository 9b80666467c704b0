"""The blackboard's keys as a schema: every key a condition or guard may read, and every field and
index inside its value, generated from the types that fill it.

`/fv/<finger>` is a `perception.state.TactileState` (its dataclass fields, their `metadata` docs and
units, the shapes of its default arrays, and its properties), `/task/element` and `/task/plates`
are the design model's element and plate (`assembly.design.model.NODE_SCHEMAS`), and the other
perception keys have the value types below. Keys a skill writes have whatever value the skill puts
there (no fields are checked). The schema is JSON Schema: `fvtree schema` publishes it, the README's
tables are made from it (`blackboard_tables`, kept equal by a test), and the validator refuses a
condition on a field that is not there (`key_problem`), with a did-you-mean.
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Iterator
from functools import cache
from typing import Any

import numpy as np

from assembly.design.model import NODE_SCHEMAS
from behaviours.skill_kit import keys
from behaviours.skill_kit.registry import SKILLS
from fvfiles.errors import did_you_mean
from perception.state import FINGERS, TactileState

NUMBER: dict[str, Any] = {"type": "number"}
FAULT: dict[str, Any] = {"type": ["string", "null"]}
BOOLEAN: dict[str, Any] = {"type": "boolean"}


def _vector(length: int) -> dict[str, Any]:
    return {"type": "array", "items": NUMBER, "minItems": length, "maxItems": length}


# The value of each perception key but the fingertips' (whose value is generated from TactileState).
VALUES: dict[str, dict[str, Any]] = {
    keys.ROBOT_POSE: _vector(6), keys.ROBOT_WRENCH: _vector(6), keys.ROBOT_FAULT: FAULT,
    keys.ROBOT_MOVING: BOOLEAN, keys.GRIPPER_WIDTH: NUMBER, keys.GRIPPER_OBJECT: BOOLEAN,
    keys.GRIPPER_FAULT: FAULT, keys.GRIPPER_MOVING: BOOLEAN, keys.ESTOP: BOOLEAN,
}
FINGER_KEYS = {f"/fv/{finger}": finger for finger in FINGERS}


def _value_schema(value: Any, hint: Any) -> dict[str, Any]:
    """JSON Schema of a dataclass field from its type hint and its value in a default instance
    (arrays: their length, unless it is 0 there, i.e. it varies)."""
    if dataclasses.is_dataclass(value):
        return dataclass_schema(value)
    if isinstance(value, np.ndarray):
        out: dict[str, Any] = {"type": "array", "items": BOOLEAN if value.dtype == bool else NUMBER}
        if value.ndim == 2:
            out["items"] = {**_vector(value.shape[1]), "items": out["items"]} if value.shape[1] else out["items"]
        if value.shape[0]:
            out["minItems"] = out["maxItems"] = value.shape[0]
        return out
    if isinstance(value, tuple):
        return {"type": "array", "items": {"type": "integer"}, "minItems": len(value), "maxItems": len(value)}
    kinds = {bool: "boolean", float: "number", int: "integer", str: "string"}
    return {"type": kinds.get(hint, "string")}


def dataclass_schema(instance: Any) -> dict[str, Any]:
    """JSON Schema of a (default) dataclass instance: its fields with their docs and units, then
    its properties (read by conditions like fields), each with its docstring's first line."""
    cls = type(instance)
    hints = typing.get_type_hints(cls)
    properties: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        schema = _value_schema(getattr(instance, f.name), hints.get(f.name))
        unit = f" [{f.metadata['unit']}]" if "unit" in f.metadata else ""
        properties[f.name] = {**schema, "description": f.metadata.get("doc", "") + unit}
    for name, member in vars(cls).items():
        if isinstance(member, property):
            schema = _value_schema(getattr(instance, name), None)
            properties[name] = {**schema, "description": (member.__doc__ or "").strip().splitlines()[0]}
    doc = (cls.__doc__ or "").strip().split(":")[0].split(".")[0]
    return {"type": "object", "title": cls.__name__, "description": doc, "properties": properties,
            "additionalProperties": False}


def _design_node(kind: str) -> dict[str, Any]:
    """The design model's schema of a kind of node, as a condition reads it."""
    return {**NODE_SCHEMAS[kind], "title": f"design {kind}"}


@cache
def key_schemas() -> dict[str, dict[str, Any]]:
    """Every blackboard key a condition may read -> JSON Schema of its value, with a description."""
    finger = dataclass_schema(TactileState(FINGERS[0], 0.0))
    out: dict[str, dict[str, Any]] = {}
    for key, meaning in keys.PERCEPTION_KEYS.items():
        if key in FINGER_KEYS:
            meaning = f"TactileState of a fingertip ({', '.join(FINGER_KEYS)})"
        out[key] = {**(finger if key in FINGER_KEYS else VALUES[key]), "description": meaning}
    out[keys.ELEMENT] = {**_design_node("element"), "description": keys.TASK_KEYS[keys.ELEMENT]}
    out[keys.PLATES] = {"type": "object", "additionalProperties": _design_node("plate"),
                        "description": keys.TASK_KEYS[keys.PLATES]}
    for name, cls in sorted(SKILLS.items()):
        for key in cls.WRITES:
            if key not in out:
                out[key] = {"description": f"written by skill {name}"}
            elif "written by skill" in out[key].get("description", ""):
                out[key]["description"] += f", {name}"
    return out


def key_problem(base: str, parts: list[str | int]) -> tuple[str, str | None] | None:
    """(what is wrong, a hint) with reading `parts` (fields, indices) of the value of `base`, or None.
    Only what the schema knows is checked: a value of unknown shape takes any field."""
    schema = key_schemas().get(base)
    where = base
    for part in parts:
        if schema is None or not schema.get("type"):
            return None  # written by a skill: its shape is the skill's
        if isinstance(part, str):
            fields = schema.get("properties", {})
            extra = schema.get("additionalProperties", False)
            if part in fields:
                schema = fields[part]
            elif isinstance(extra, dict):
                schema = extra
            else:
                if not fields:
                    return f"{where} is {_kind(schema)}: it has no field {part!r}", None
                return (f"{where} ({_kind(schema)}) has no field {part!r}",
                        did_you_mean(part, fields) or f"its fields: {', '.join(fields)}")
            where = f"{where}.{part}"
        else:
            if "array" not in _types(schema):
                return f"{where} is not a list: it takes no index [{part}]", None
            length = schema.get("maxItems")
            if length is not None and not -length <= part < length:
                return f"{where} has {length} items: index [{part}] is out of range", f"use 0 to {length - 1}"
            schema = schema.get("items", {})
            where = f"{where}[{part}]"
    return None


def _types(schema: dict[str, Any]) -> list[str]:
    kind = schema.get("type", [])
    return [kind] if isinstance(kind, str) else list(kind)


def _kind(schema: dict[str, Any]) -> str:
    """A value's type as the README's tables say it: `3 x number`, `N x 2 x number`, `string or null`."""
    if "enum" in schema:
        return "one of " + ", ".join(map(str, schema["enum"]))
    if "anyOf" in schema:
        return " or ".join(_kind(s) for s in schema["anyOf"])
    kinds = _types(schema)
    if kinds == ["array"]:
        return f"{schema.get('maxItems', 'N')} x {_kind(schema.get('items', {}))}"
    return schema.get("title") or " or ".join(kinds) or "any"


def _rows(schema: dict[str, Any], path: str) -> Iterator[tuple[str, str, str]]:
    """(field path, type, meaning) of a value and every field inside it."""
    yield path, _kind(schema), schema.get("description", "")
    for name, field in schema.get("properties", {}).items():
        if name != "kind":  # a design node's kind: always the same
            yield from _rows(field, f"{path}.{name}")
    if isinstance(schema.get("additionalProperties"), dict):
        yield from _rows(schema["additionalProperties"], f"{path}.<id>")


def blackboard_tables() -> str:
    """The README's tables of the blackboard (Markdown): one per namespace, one row per field."""
    groups = {"/fv/<finger>": ["/fv/left"], "/robot": [], "/gripper": [], "/task": []}
    for key in key_schemas():
        for group, members in groups.items():
            if key.startswith(group + "/") and group != "/fv/<finger>":
                members.append(key)
    out = []
    for group, members in groups.items():
        out += [f"`{group}`:", "", "| key or field | type | meaning |", "|---|---|---|"]
        for key in members:
            schema = key_schemas()[key]
            for path, kind, meaning in _rows(schema, "/fv/<finger>" if key in FINGER_KEYS else key):
                out.append(f"| `{path}` | {kind} | {meaning.replace('|', '/')} |")
        out.append("")
    return "\n".join(out).rstrip() + "\n"


def blackboard_schema() -> dict[str, Any]:
    """JSON Schema `$defs` entry: an object whose properties are the blackboard keys (for editors
    and tools; the condition `key` field lists every field path as an example)."""
    return {"type": "object", "description": "the blackboard keys conditions and guards read, with their fields",
            "properties": key_schemas()}


def field_paths() -> list[str]:
    """Every key and field path a condition may name (indices left out)."""
    return [path for key, schema in key_schemas().items() for path, _, _ in _rows(schema, key)]
