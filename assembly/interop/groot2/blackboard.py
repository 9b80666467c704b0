"""The blackboards Groot2 asks for (`BLACKBOARD`), as BT.CPP sends them: msgpack of
`{blackboard name: {key: JSON value}}`.

BT.CPP names a blackboard by its subtree: the main tree by its ID, each subtree instance by its
path. In fvtree the main tree's is py_trees' blackboard (perception, robot, task keys), read as it
stands when asked; a subtree instance's holds its params (the ports of its `<SubTree>`), what BT.CPP
keeps on a subtree's own blackboard. Values become JSON: dataclasses and mappings as objects,
arrays and sequences as lists (large arrays as a summary), numbers that are not finite and other
objects as text. Names that are no blackboard are left out, as BT.CPP does.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from enum import Enum
from typing import Any

import msgpack
import numpy as np
from py_trees.blackboard import Blackboard

MAX_ITEMS = 256  # longer arrays and lists are summarised
MAX_DEPTH = 6


def jsonable(value: Any, depth: int = 0) -> Any:
    """`value` as plain JSON data (None, bool, int, float, str, list, dict)."""
    if value is None or isinstance(value, (bool, str, int)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, np.generic):
        return jsonable(value.item(), depth)
    if isinstance(value, Enum):
        return value.name
    if depth >= MAX_DEPTH:
        return repr(value)[:200]
    if isinstance(value, np.ndarray):
        if value.size > MAX_ITEMS:
            return f"array of shape {list(value.shape)}, {value.dtype}"
        return jsonable(value.tolist(), depth + 1)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name), depth + 1) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): jsonable(v, depth + 1) for k, v in list(value.items())[:MAX_ITEMS]}
    if isinstance(value, (list, tuple, set, frozenset)):
        items = list(value)
        if len(items) > MAX_ITEMS:
            return f"{type(value).__name__} of {len(items)} items"
        return [jsonable(v, depth + 1) for v in items]
    return repr(value)[:200]


def tree_blackboard() -> dict[str, Any]:
    """py_trees' blackboard as it stands, each value as JSON."""
    storage = dict(Blackboard.storage)  # a copy: the tick may add keys meanwhile
    return {key: jsonable(value) for key, value in sorted(storage.items())}


def blackboards_dump(request: str, main_id: str, subtree_ports: Mapping[str, Mapping[str, Any]]) -> bytes:
    """The msgpack reply to a `BLACKBOARD` request naming blackboards joined by ';'."""
    out: dict[str, Any] = {}
    for name in request.split(";"):
        if name == main_id:
            out[name] = tree_blackboard()
        elif name in subtree_ports:
            out[name] = jsonable(dict(subtree_ports[name]))
    return msgpack.packb(out or None, use_bin_type=True)
