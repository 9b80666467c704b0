"""Values in BehaviorTree.CPP XML attributes, both ways: typed YAML values as port strings, and
`key op value` conditions as BT.CPP scripts.

A port is a string that BT.CPP converts by the port's type, so a value is read back by the type
our side declares (a skill's or a subtree's param, a decorator's field): vectors are `;`-separated
as BT.CPP's `convertFromString<std::vector<double>>` reads them, booleans `true`/`false`, and a
`$param` of a subtree body is the port reference `{param}`. In scripts our blackboard keys are
globals, so they are read from BT.CPP's root blackboard (`@name`); `/`, `.` and `[i]` cannot stand
in a script identifier and are spelled `_` (path separator), `__` (attribute) and `__i` / `__m1`
(index), then looked up among the keys the project knows when reading back.
"""

from __future__ import annotations

import math
import re
from typing import Any

from assembly.nodes.conditions import split_key

PORT_REF = re.compile(r"^\{([A-Za-z_]\w*)\}$")
SCRIPT_OPS = {"eq": "==", "ne": "!=", "lt": "<", "le": "<=", "gt": ">", "ge": ">="}
_SCRIPT = re.compile(r"^\s*@([A-Za-z_]\w*)\s*(==|!=|<=|>=|<|>)\s*(.+?)\s*$")
_NUMBER = re.compile(r"^-?\d+(\.\d*)?([eE][-+]?\d+)?$")


class PortError(ValueError):
    """A value that has no spelling on the other side (the message says why)."""


def to_port(value: Any) -> str:
    """The port string of a YAML value (`$param` becomes the port reference `{param}`)."""
    if isinstance(value, str) and value.startswith("$"):
        return "{" + value[1:] + "}"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return _number(value)
    if isinstance(value, (list, tuple)):
        if any(isinstance(v, (list, tuple, dict, str, bool)) for v in value):
            raise PortError(f"only lists of numbers have a port spelling, got {value!r}")
        return ";".join(_number(v) for v in value)
    if isinstance(value, str):
        if PORT_REF.match(value):
            raise PortError(f"the string {value!r} would read back as a port reference")
        return value
    raise PortError(f"no port spelling for {value!r}")


def _number(value: float) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        raise PortError(f"non-finite number {value!r}")
    return repr(value)


def from_port(text: str, type_: str) -> Any:
    """The YAML value of a port string, read as a param of `type_` (float, int, bool, str, vector);
    a port reference `{p}` becomes `$p`. PortError says why a string does not fit."""
    ref = PORT_REF.match(text)
    if ref:
        return "$" + ref.group(1)
    if type_ == "str":
        return text
    if type_ == "bool":
        if text not in ("true", "false"):
            raise PortError(f"expected true or false, got {text!r}")
        return text == "true"
    if type_ == "vector":
        return [_read_number(part, "float") for part in text.split(";")] if text.strip() else []
    return _read_number(text, type_)


def _read_number(text: str, type_: str) -> int | float:
    text = text.strip()
    if not _NUMBER.match(text):
        raise PortError(f"expected a number, got {text!r}")
    if type_ == "int":
        if not re.match(r"^-?\d+$", text):
            raise PortError(f"expected an integer, got {text!r}")
        return int(text)
    value = float(text)
    return int(text) if re.match(r"^-?\d+$", text) else value


def literal(text: str) -> Any:
    """A value whose type nobody declares (a condition's `value`): number, bool, quoted string."""
    text = text.strip()
    if text in ("true", "false"):
        return text == "true"
    if _NUMBER.match(text):
        return _read_number(text, "float")
    if len(text) >= 2 and text[0] == text[-1] == "'":
        return text[1:-1]
    ref = re.match(r"^[A-Za-z_]\w*$", text)
    if ref:
        return "$" + text  # a subtree port, read by name in a script
    raise PortError(f"cannot read the value {text!r}; use a number, true/false or a 'quoted string'")


def script_identifier(key: str) -> str:
    """`@fv_left__slip` from `/fv/left.slip`, `@robot_pose__2` from `/robot/pose[2]`."""
    base, parts = split_key(key)
    name = base.strip("/").replace("/", "_")
    for part in parts:
        if isinstance(part, int):
            name += f"__{part}" if part >= 0 else f"__m{-part}"
        elif re.match(r"^m\d+$", part) or part.isdigit():
            raise PortError(f"attribute {part!r} of {key!r} would read back as an index")
        else:
            name += f"__{part}"
    return "@" + name


def condition_script(key: str, op: str, value: Any) -> str | None:
    """The BT.CPP script of a condition, or None when a script cannot say it (`exists`, lists,
    a `$param` key)."""
    if op not in SCRIPT_OPS or key.startswith("$"):
        return None
    if isinstance(value, str) and value.startswith("$"):
        right = value[1:]
    elif isinstance(value, bool):
        right = "true" if value else "false"
    elif isinstance(value, (int, float)):
        right = _number(value)
    elif isinstance(value, str) and "'" not in value:
        right = f"'{value}'"
    else:
        return None
    return f"{script_identifier(key)} {SCRIPT_OPS[op]} {right}"


def read_condition_script(code: str, known_keys: set[str]) -> dict:
    """`{key, op, value}` of a script `@name OP value`; PortError for any other script."""
    m = _SCRIPT.match(code)
    if not m:
        raise PortError(f"only comparisons '@key OP value' have an equivalent, got {code!r}")
    name, op_text, right = m.groups()
    op = next(k for k, v in SCRIPT_OPS.items() if v == op_text)
    return {"key": key_of_identifier(name, known_keys), "op": op, "value": literal(right)}


def key_of_identifier(name: str, known_keys: set[str]) -> str:
    """`/fv/left.slip` from the script identifier `fv_left__slip` (see `script_identifier`), looked
    up among `known_keys`; PortError if it spells none of them, or several."""
    base, *parts = name.split("__")
    bases = [k for k in known_keys if k.strip("/").replace("/", "_") == base]
    if len(bases) != 1:
        raise PortError(f"@{base} is {'ambiguous' if bases else 'not a blackboard key of this project'}")
    key = bases[0]
    for part in parts:
        key += f"[{part}]" if part.isdigit() else f"[-{part[1:]}]" if re.match(r"^m\d+$", part) else f".{part}"
    return key
