"""The design model: elements, plates and precedence as a networkx DiGraph in node-link JSON
(`edges="edges"`), checked whole when it is read, and its build order.

Node kinds (lengths in m, poses [x, y, z, rx, ry, rz] in the robot base frame):
  element: size [length, width, depth], pick_pose, plate (id it props), mass (kg),
           planned_pose (optional), status planned|placing|placed, asbuilt_pose, measured_load
  plate:   origin [x, y, z_soffit] (left support), span, width
An edge u -> v means u must be in place before v. The model holds the design only: what a
simulated cell knows beyond it (the plates' loads) is in the scene file next to it. The JSON
Schema of a design file is `design_schema()` (trees/design/design.schema.json): unknown fields,
wrong types, non-finite numbers, non-positive sizes and unknown statuses are refused with the line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import networkx as nx

from assembly.errors import TreeError
from fvfiles.errors import did_you_mean
from fvfiles.json_source import load_json
from fvfiles.schema_check import object_problems, short_json
from fvfiles.yaml_source import Located

# placing: released but not yet recorded as standing. A live link (assembly.design.link) also shows
# the passing states picking and failed, which no design or as-built file holds.
STATUSES = ("planned", "placing", "placed")


def _vector(length: int, doc: str, items: dict | None = None) -> dict:
    return {"type": "array", "items": items or {"type": "number"}, "minItems": length, "maxItems": length,
            "description": doc}


# Within 10 m and 10 rad: beyond any arm's reach, and far from where the pose arithmetic overflows.
_POSE = _vector(6, "[x, y, z, rx, ry, rz] in the robot base frame (m, rotation vector in rad)",
                {"type": "number", "minimum": -10, "maximum": 10})
_POSITIVE = {"type": "number", "exclusiveMinimum": 0}
# JSON Schema of each kind of design node: the single source of what a design may hold (the
# checks below read it, `design_schema()` publishes it as trees/design/design.schema.json).
NODE_SCHEMAS = {
    "element": {
        "type": "object", "additionalProperties": False, "required": ["id", "kind", "size", "pick_pose", "plate"],
        "description": "an element to place; runs add status, asbuilt_pose and measured_load in asbuilt.json",
        "properties": {
            "id": {"type": "string"}, "kind": {"const": "element"},
            "size": _vector(3, "[length, width, depth] (m)", _POSITIVE),
            "pick_pose": {**_POSE, "description": "where it is picked up: " + _POSE["description"]},
            "plate": {"type": "string", "description": "id of the plate it props"},
            "mass": {**_POSITIVE, "default": 0.4, "description": "kg"},
            "planned_pose": _POSE,
            "status": {"enum": list(STATUSES), "default": "planned"},
            "asbuilt_pose": {"anyOf": [_POSE, {"type": "null"}]},
            "measured_load": {"type": ["number", "null"], "description": "N"},
            "cell": {"type": "string", "description": "the cell that placed it, when several cells build one design"},
        },
    },
    "plate": {
        "type": "object", "additionalProperties": False, "required": ["id", "kind", "origin", "span", "width"],
        "description": "a bendable plate, simply supported",
        "properties": {
            "id": {"type": "string"}, "kind": {"const": "plate"},
            "origin": _vector(3, "[x, y, z_soffit] of the left support (m)"),
            "span": {**_POSITIVE, "description": "m"}, "width": {**_POSITIVE, "description": "m"},
        },
    },
}
EDGE_SCHEMA = {"type": "object", "additionalProperties": False, "required": ["source", "target"],
               "description": "source must be in place before target",
               "properties": {"source": {"type": "string"}, "target": {"type": "string"}}}
DOCUMENT_SCHEMA: dict[str, Any] = {
    "type": "object", "additionalProperties": False, "required": ["nodes", "edges"],
    "properties": {
        "directed": {"const": True}, "multigraph": {"const": False},
        "graph": {"type": "object", "additionalProperties": False,
                  "properties": {"name": {"type": "string"}, "units": {"const": "m"}, "doc": {"type": "string"}}},
        "nodes": {"type": "array", "items": {"type": "object"}}, "edges": {"type": "array", "items": {"type": "object"}},
    },
}
WAIT = "<wait>"  # what a dispatcher answers while no element may be built yet (not a valid element id here)


def design_schema() -> dict:
    """JSON Schema (draft 2020-12) of a design file, for editors and for `trees/design/design.schema.json`."""
    nodes = {"type": "array", "items": {"oneOf": [{"$ref": f"#/$defs/{kind}"} for kind in NODE_SCHEMAS]}}
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "title": "fvtree design model",
            "description": "networkx node-link JSON (edges=\"edges\") of elements, plates and precedence; lengths in m. "
                           "Also checked: ids unique, every element's plate is a plate, edges join known nodes, "
                           "no precedence cycle.",
            **DOCUMENT_SCHEMA, "properties": {**DOCUMENT_SCHEMA["properties"], "nodes": nodes,
                                              "edges": {"type": "array", "items": EDGE_SCHEMA}},
            "$defs": NODE_SCHEMAS}


def node_problems(node: dict) -> list[tuple[str, str | None, str | None]]:
    """(message, field, hint) for each way a design node (with its id and kind) breaks its schema."""
    kind = node.get("kind")
    if not isinstance(kind, str) or kind not in NODE_SCHEMAS:
        return [(f"node {node.get('id')!r}: kind must be 'element' or 'plate', got {short_json(kind)}", "kind",
                 did_you_mean(kind, NODE_SCHEMAS) if isinstance(kind, str) else None)]
    return list(object_problems(node, NODE_SCHEMAS[kind], f"{kind} {node.get('id')!r}"))


class DesignModel:
    """A validated design graph."""

    def __init__(self, graph: nx.DiGraph, path: str | Path | None = None, lines: dict[Any, int] | None = None):
        self.graph = graph
        self.path = Path(path) if path is not None else None  # the design file, if loaded from one
        self.source = str(path) if path is not None else "<memory>"
        self._lines = lines or {}  # node id -> line in the design file
        self._validate()

    @classmethod
    def load(cls, path: str | Path) -> DesignModel:
        """Read and check a design file whole (see `design_schema`); a located TreeError otherwise."""
        path = Path(path)
        data = load_json(path)
        if isinstance(data, Located) and "links" in data and "edges" not in data:
            raise TreeError("edges are under 'links' (networkx < 3.6 default); rename the key to 'edges'",
                            str(path), data.line_of("links"))
        if not isinstance(data, Located):  # every JSON object load_json reads is one
            raise TreeError("not a node-link graph: a JSON object with 'nodes' and 'edges'", str(path), 1)
        for message, key, hint in object_problems(data, DOCUMENT_SCHEMA, "design"):
            raise TreeError(message, str(path), data.line_of(key), hint=hint)
        lines = {}
        for node in data["nodes"]:
            if not isinstance(node.get("id"), str) or node["id"] in lines:
                what = "a string id" if not isinstance(node.get("id"), str) else f"a unique id ({node['id']!r} twice)"
                raise TreeError(f"every node needs {what}", str(path), node.line_of("id"))
            lines[node["id"]] = node.line
        for i, edge in enumerate(data["edges"]):
            for message, key, hint in object_problems(edge, EDGE_SCHEMA, f"edge {i}"):
                raise TreeError(message, str(path), edge.line_of(key), hint=hint)
            for end in ("source", "target"):
                if edge[end] not in lines:
                    raise TreeError(f"edge {end} {edge[end]!r} is not a node", str(path), edge.line_of(end),
                                    hint=did_you_mean(edge[end], lines))
        graph = nx.node_link_graph(data, directed=True, edges="edges")
        return cls(nx.DiGraph(graph), path, lines)

    def to_data(self) -> dict:
        return nx.node_link_data(self.graph, edges="edges")

    def _fail(self, message: str, hint: str | None = None, node: Any = None):
        raise TreeError(message, self.source, self._lines.get(node), hint=hint)

    def _validate(self) -> None:
        for node, attrs in self.graph.nodes(data=True):
            kind = attrs.get("kind")
            if "sim_load" in attrs:
                scene = f"{self.path.stem}.scene.yaml" if self.path else "the scene file next to the design"
                self._fail(f"{kind} {node!r}: field 'sim_load' is simulation data, not design",
                           f"move it to {scene}: 'plates: {{{node}: {{EI: .., w: .., P: .., c: .., k: ..}}}}'", node)
            for message, _, hint in node_problems({"id": node, **attrs}):
                self._fail(message, hint, node)
        plates = self.plates()
        for eid, attrs in self.elements().items():
            if attrs.get("plate") not in plates:
                self._fail(f"element {eid!r} props plate {attrs.get('plate')!r}, which is not in "
                           "the model", did_you_mean(attrs.get("plate"), plates), eid)
        if not nx.is_directed_acyclic_graph(self.graph):
            cycle = " -> ".join(str(u) for u, _ in nx.find_cycle(self.graph))
            self._fail(f"precedence graph has a cycle: {cycle}", "no valid build order exists")

    def elements(self) -> dict[str, dict]:
        return {n: a for n, a in self.graph.nodes(data=True) if a.get("kind") == "element"}

    def plates(self) -> dict[str, dict]:
        return {n: a for n, a in self.graph.nodes(data=True) if a.get("kind") == "plate"}

    def element(self, eid: str) -> dict:
        return {"id": eid, **self.graph.nodes[eid]}

    def build_order(self) -> list[str]:
        """Elements in a deterministic topological order (ties broken by id)."""
        order = nx.lexicographical_topological_sort(self.graph, key=str)
        return [n for n in order if self.graph.nodes[n].get("kind") == "element"]

    def is_placed(self, eid: str) -> bool:
        return self.graph.nodes[eid].get("status") == "placed"

    def scene_args(self) -> dict:
        """Plain-data description of elements and plates for building a simulated scene, with
        the design file's path (None in memory): the scene reads its own file next to it."""
        return {
            "elements": [self.element(e) for e in self.build_order()],
            "plates": [{"id": p, **a} for p, a in self.plates().items()],
            "design_file": None if self.path is None else str(self.path),
        }
