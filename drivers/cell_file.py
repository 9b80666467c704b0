"""Reading cell files (`drivers/cells/*.yaml`): finding one by name, its sections, and config
dataclasses filled from them, with errors that name the file, line and dotted field."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from fvfiles.errors import FvtreeError, did_you_mean, field_name
from fvfiles.schema_check import schema_problem
from fvfiles.yaml_source import Located, SourceError, load_file

CELLS_DIR = Path(__file__).parent / "cells"


class CellFileError(FvtreeError):
    """A cell file is missing, malformed or names an unknown field; `field` is a dotted path."""

    def __init__(self, path: str | Path, field: str, message: str, hint: str | None = None,
                 line: int | None = None):
        super().__init__(message, str(path), line if line is not None else line_of_field(path, field),
                         field or None, hint)
        self.path = str(path)


def line_of_field(path: str | Path, field: str) -> int | None:
    """Line (1-based) of a dotted field (`safety.max_speed`) in a YAML file, if it is there."""
    if not field:
        return None
    try:
        node = load_file(path)
    except SourceError:
        return None
    line = None
    for part in field.split("."):
        if not isinstance(node, Located) or part not in node:
            break
        line, node = node.line_of(part), node[part]
    return line


def resolve_cell_path(name_or_path: str) -> Path:
    """`sim` -> the packaged drivers/cells/sim.yaml; anything else is a path."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.exists():
        return p
    return CELLS_DIR / f"{name_or_path}.yaml"


def read_cell_file(path: Path) -> dict:
    """The cell file as a mapping with a `kind`, or CellFileError. Read by the hardened reader of
    `fvfiles.yaml_source` (regular files only, size, nesting and aliases capped, finite numbers)."""
    path = Path(path)
    if not path.exists():
        known = ", ".join(sorted(p.stem for p in CELLS_DIR.glob("*.yaml")))
        raise CellFileError(path, "", f"no such cell file (packaged cells: {known})")
    try:
        data = load_file(path)
    except SourceError as exc:
        raise CellFileError(path, "", exc.message, exc.hint, exc.line) from None
    if not isinstance(data, dict) or "kind" not in data:
        raise CellFileError(path, "kind", "a cell file is a mapping with 'kind: sim' or 'kind: real'")
    if not isinstance(data["kind"], str):
        raise CellFileError(path, "kind", f"must be a name (sim, real), got {data['kind']!r}")
    return data


def check_known(path: Path, mapping: dict, known: Iterable[str], where: str = "") -> None:
    """CellFileError for the first field of `mapping` not in `known`, with a did-you-mean."""
    known = set(known)
    unknown = sorted(set(mapping) - known, key=str)
    if unknown:
        key = unknown[0]
        if field_name(key).startswith("'"):
            raise CellFileError(path, f"{where}{key}", "unknown field",
                                did_you_mean(key, known) or f"known: {', '.join(sorted(known))}")
        raise CellFileError(path, where.rstrip("."), f"unknown field {field_name(key)}",  # its line, not its text
                            f"known: {', '.join(sorted(known))}", line=_line_of_key(mapping, key))


def _line_of_key(mapping: dict, key: object) -> int | None:
    """The line of `key` in a mapping read from a file, when it knows it."""
    return mapping.line_of(key) if isinstance(mapping, Located) else None


def section(path: Path, data: dict, key: str, required: bool = False, known: Iterable[str] | None = None,
            where: str = "") -> dict:
    """The mapping section `key` of `data` (at dotted prefix `where`), checked against `known`."""
    value = data.get(key)
    if value is None:
        if required:
            raise CellFileError(path, where + key, "missing section")
        return {}
    if not isinstance(value, dict):
        raise CellFileError(path, where + key, "must be a mapping")
    if known is not None:
        check_known(path, value, known, f"{where}{key}.")
    return value


def number(minimum: float, maximum: float, above: bool = False) -> dict:
    """The JSON Schema of a finite number in [minimum, maximum] (above: minimum excluded)."""
    return {"type": "number", "exclusiveMinimum" if above else "minimum": minimum, "maximum": maximum}


def check_values(path: Path, mapping: dict, schemas: dict[str, dict], where: str = "") -> None:
    """CellFileError naming the field for the first value of `mapping` that breaks its JSON Schema
    in `schemas` (by field name; numbers finite, never booleans or strings): a cell file's value of
    the wrong type is refused when the file is read, not met as a TypeError in the middle of a run."""
    for key, schema in schemas.items():
        if key in mapping and (problem := schema_problem(mapping[key], schema)):
            raise CellFileError(path, f"{where}{key}", problem)


def config_from(path: Path, where: str, cls: type, values: dict, driver: str | None = None) -> Any:
    """Instantiate a config dataclass from a section, with errors that name the field."""
    values = dict(values)
    if driver is not None:
        got = values.pop("driver", driver)
        if got != driver:
            raise CellFileError(path, f"{where}.driver", f"unsupported driver {got!r}; expected {driver!r}")
    check_known(path, values, (f.name for f in dataclasses.fields(cls)), f"{where}.")
    for name, value in values.items():  # YAML lists -> the tuples the dataclasses declare
        if isinstance(value, list):
            values[name] = tuple(value)
    try:
        return cls(**values)
    except (TypeError, ValueError) as exc:
        raise CellFileError(path, where, str(exc)) from None
