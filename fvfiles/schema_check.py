"""Values from files checked against the subset of JSON Schema the project's formats use (type,
const, enum, anyOf, minimum, exclusiveMinimum, maximum, minLength, object properties and required
fields, items and item counts): the reason a value does not match, worded for the person who wrote
it. Numbers must be finite: NaN and infinity never match "number". Other keywords ($ref,
additionalProperties as a schema, default, description) are not checked here."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from typing import Any

from fvfiles.errors import did_you_mean, did_you_mean_field, field_name

_JSON_TYPES = {"string": str, "array": list, "object": dict, "boolean": bool, "null": type(None)}


def schema_problem(value: Any, schema: dict) -> str | None:
    """Why `value` does not match `schema` (the subset of JSON Schema used above), or None.
    Numbers must be finite: NaN and infinity never match "number"."""
    if "anyOf" in schema:
        problems = [schema_problem(value, option) for option in schema["anyOf"]]
        return None if None in problems else " or ".join(p for p in problems if p)
    if "const" in schema and not _same_json(value, schema["const"]):
        return f"must be {json.dumps(schema['const'])}, got {short_json(value)}"
    if "enum" in schema and (not isinstance(value, str) or value not in schema["enum"]):
        return f"must be one of {', '.join(schema['enum'])}, got {short_json(value)}" + (
            f" ({did_you_mean(value, schema['enum'])})" if did_you_mean(value, schema["enum"]) else "")
    types = schema.get("type")
    if types is not None:
        types = [types] if isinstance(types, str) else types
        if not any(is_json_type(value, t) for t in types):
            return f"must be {' or '.join(types)}" + (" (finite)" if "number" in types else "") + f", got {short_json(value)}"
    if is_json_type(value, "number") and (problem := _range_problem(value, schema)):
        return problem
    if isinstance(value, str) and len(value) < schema.get("minLength", 0):
        return ("must not be empty" if schema["minLength"] == 1
                else f"must be at least {schema['minLength']} characters long, got {short_json(value)}")
    if isinstance(value, dict) and "properties" in schema:
        return next((f"{message}" + (f" ({hint})" if hint else "") for message, _, hint in
                     object_problems(value, schema, "")), None)
    if isinstance(value, list):
        if not schema.get("minItems", 0) <= len(value) <= schema.get("maxItems", len(value)):
            return f"must be a list of {schema['minItems']} numbers, got {short_json(value)}"
        for i, item in enumerate(value):
            problem = schema_problem(item, schema.get("items", {}))
            if problem:
                return f"item {i} {problem}"
    return None


def _range_problem(number: float, schema: dict) -> str | None:
    """Why a number is outside the bounds of `schema`, or None."""
    if "minimum" in schema and not number >= schema["minimum"]:
        return f"must be at least {schema['minimum']}, got {number}"
    if "exclusiveMinimum" in schema and not number > schema["exclusiveMinimum"]:
        return f"must be above {schema['exclusiveMinimum']}, got {number}"
    if "maximum" in schema and not number <= schema["maximum"]:
        return f"must be at most {schema['maximum']}, got {number}"
    return None


def _same_json(value: Any, const: Any) -> bool:
    """Equal as JSON values: numbers by value (1 and 1.0 alike), anything else of the same type too
    (true is not 1)."""
    if is_json_type(value, "number") and is_json_type(const, "number"):
        return value == const
    return type(value) is type(const) and value == const


def is_json_type(value: Any, json_type: str) -> bool:
    if json_type == "number":
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    return isinstance(value, _JSON_TYPES[json_type]) and (json_type == "boolean" or not isinstance(value, bool))


def short_json(value: Any) -> str:
    text = json.dumps(value, default=str) if not isinstance(value, float) or math.isfinite(value) else str(value)
    return text if len(text) <= 60 else text[:57] + "..."


def object_problems(obj: dict, schema: dict, what: str) -> Iterator[tuple[str, str | None, str | None]]:
    """(message, field, hint) for each way a JSON object breaks its object schema."""
    known = schema["properties"]
    for key in obj:
        if key not in known:
            yield (f"{what}: unknown field {field_name(key)}", key,
                   did_you_mean_field(key, known) or f"known: {', '.join(known)}")
    for key in schema.get("required", ()):
        if key not in obj:
            yield f"{what}: missing field {key!r}", None, None
    for key, value in obj.items():
        problem = schema_problem(value, known[key]) if key in known else None
        if problem:
            yield f"{what}: field {key!r} {problem}", key, None
