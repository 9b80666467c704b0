"""Design updates from the outside (a designer's Grasshopper, a script): read a message safely and
apply it to the model between two elements, all or nothing.

An update is {"update": ID, "elements": [element nodes], "edges": [{"source", "target"}]}: an
element node is a design-file element (assembly.design.model.NODE_SCHEMAS) whose poses may also be
COMPAS frames; a new id adds the element, a known one replaces its design fields. What the cell
records (status, asbuilt_pose, measured_load, cell) cannot be sent. Elements already placed, being
placed or being built are never changed, nor made to wait for another element: such an update is a
`Conflict`; anything malformed is an `UpdateError`. Payloads are plain JSON read with a size and
depth limit; the only COMPAS type read is compas.geometry/Frame (no other class is imported)."""

from __future__ import annotations

import json
from typing import Any

import networkx as nx
from compas.geometry import Frame

from assembly.design.link.compas_data import POSE_FIELDS, frame_to_pose
from assembly.design.model import DesignModel, node_problems
from assembly.errors import TreeError

MAX_BYTES = 256_000  # a design update is a few elements, not a whole city
MAX_DEPTH = 12
CELL_FIELDS = ("status", "asbuilt_pose", "measured_load", "cell")  # the cell records these
FROZEN = ("placing", "placed")  # an element in one of these states (or being built) is not changed


class UpdateError(ValueError):
    """A design update that cannot be read or would break the design; the message says why, and
    `update` is the update's id when it could be read."""

    update: str | int | None = None


class Conflict(UpdateError):
    """A design update that would change an element already built or being built."""

    def __init__(self, element: str, reason: str):
        super().__init__(reason)
        self.element = element


def parse(payload: bytes) -> dict:
    """The update in a raw message, checked for shape (not yet against the model)."""
    if len(payload) > MAX_BYTES:
        raise UpdateError(f"message of {len(payload)} bytes; at most {MAX_BYTES}")
    try:
        data = json.loads(payload.decode("utf-8"), parse_constant=_no_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise UpdateError(f"not JSON: {exc}") from None
    _check_depth(data, 0)
    if not isinstance(data, dict):
        raise UpdateError(f"an update is a JSON object, got {type(data).__name__}")
    unknown = set(data) - {"update", "elements", "edges"}
    if unknown:
        raise UpdateError(f"unknown field(s) {', '.join(sorted(unknown))}; an update has update, elements, edges")
    if not isinstance(data.get("update"), (str, int)) or isinstance(data.get("update"), bool):
        raise UpdateError("field 'update' (an id echoed in the answers) must be a string or an integer")
    try:
        elements, edges = data.get("elements", []), data.get("edges", [])
        if not isinstance(elements, list) or not isinstance(edges, list) or not (elements or edges):
            raise UpdateError("fields 'elements' and 'edges' must be lists, and one of them not empty")
        return {"update": data["update"], "elements": [_element(e, i) for i, e in enumerate(elements)],
                "edges": [_edge(e, i) for i, e in enumerate(edges)]}
    except UpdateError as exc:
        exc.update = data["update"]
        raise


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number")


def _check_depth(value: Any, depth: int) -> None:
    if depth > MAX_DEPTH:
        raise UpdateError(f"nested deeper than {MAX_DEPTH} levels")
    for item in value.values() if isinstance(value, dict) else value if isinstance(value, list) else ():
        _check_depth(item, depth + 1)


def _element(node: Any, i: int) -> dict:
    if not isinstance(node, dict):
        raise UpdateError(f"elements[{i}] must be an object (a design element)")
    node = {"kind": "element", **node}
    for pose_key, frame_key in POSE_FIELDS.items():  # a COMPAS frame under either name, or a 6-list
        value = node.pop(frame_key, node.get(pose_key))
        if isinstance(value, dict):
            value = frame_to_pose(parse_frame(value, f"elements[{i}].{frame_key}"))
        if value is not None or pose_key in node:
            node[pose_key] = value
    sent = [f for f in CELL_FIELDS if f in node]
    if sent:
        raise UpdateError(f"elements[{i}] ({node.get('id')!r}): field(s) {', '.join(sent)} are recorded by the "
                          "cell, not sent")
    problems = node_problems(node)
    if problems:
        message, _, hint = problems[0]
        raise UpdateError(f"elements[{i}]: {message}" + (f" ({hint})" if hint else ""))
    return node


def parse_frame(value: object, where: str) -> Frame:
    """The compas.geometry/Frame in plain JSON data (no other class is ever built)."""
    if not isinstance(value, dict) or value.get("dtype") != "compas.geometry/Frame" or not isinstance(value.get("data"), dict):
        raise UpdateError(f"{where}: a pose is a 6-list or a compas.geometry/Frame, got {json.dumps(value)[:60]}")
    try:
        return Frame.__from_data__(value["data"])
    except (KeyError, TypeError, ValueError) as exc:
        raise UpdateError(f"{where}: not a frame ({exc})") from None


def _edge(edge: Any, i: int) -> dict:
    if not isinstance(edge, dict) or set(edge) != {"source", "target"} or not all(
            isinstance(v, str) for v in edge.values()):
        raise UpdateError(f"edges[{i}] must be {{\"source\": ID, \"target\": ID}} (source before target)")
    return dict(edge)


def apply(model: DesignModel, update: dict, building: str | None = None) -> list[str]:
    """Apply a parsed update to the model, all or nothing; the element ids it adds or changes.
    `building` is the element the cell is on (its status may still read planned)."""
    graph = model.graph.copy()
    changed = []
    for node in update["elements"]:
        eid = node["id"]
        _refuse_if_frozen(model, eid, building, f"{eid} cannot change")
        if eid in graph and graph.nodes[eid].get("kind") != "element":
            raise UpdateError(f"{eid!r} is a plate; an update adds or changes elements")
        kept = {k: v for k, v in graph.nodes[eid].items() if k in CELL_FIELDS} if eid in graph else {}
        graph.add_node(eid)  # a known element keeps its edges
        graph.nodes[eid].clear()
        graph.nodes[eid].update({k: v for k, v in node.items() if k != "id"}, **kept)
        changed.append(eid)
    for edge in update["edges"]:
        for end in ("source", "target"):
            if edge[end] not in graph:
                raise UpdateError(f"edge {edge['source']} -> {edge['target']}: no element {edge[end]!r}")
        _refuse_if_frozen(model, edge["target"], building, f"{edge['target']} cannot be made to wait for {edge['source']}")
        graph.add_edge(edge["source"], edge["target"])
        changed.append(edge["target"])
    if not nx.is_directed_acyclic_graph(graph):
        raise UpdateError("the update makes a precedence cycle: " + " -> ".join(u for u, _ in nx.find_cycle(graph)))
    try:
        DesignModel(graph)  # the whole design checked as a design file is
    except TreeError as exc:
        raise UpdateError(exc.message + (f" ({exc.hint})" if exc.hint else "")) from None
    model.graph = graph
    return list(dict.fromkeys(changed))


def _refuse_if_frozen(model: DesignModel, eid: str, building: str | None, what: str) -> None:
    status = model.graph.nodes[eid].get("status", "planned") if eid in model.graph else None
    if eid == building or status in FROZEN:
        raise Conflict(eid, f"{what}: it is {'being built' if eid == building and status not in FROZEN else status}")
