"""The design model: elements, plates and precedence as a networkx DiGraph in node-link JSON
(`edges="edges"`), its build order, and the bridge that writes as-built data back atomically.

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

import json
import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

from assembly.errors import TreeError
from assembly.files import append_json_line_or_stderr, atomic_write_json, read_json_lines
from perception.errors import did_you_mean
from perception.yaml_source import Located, read_text

# placing: released but not yet recorded as standing. A live link (assembly.design_link) also shows
# the passing states picking and failed, which no design or as-built file holds.
STATUSES = ("planned", "placing", "placed")


def _vector(length: int, doc: str, items: dict | None = None) -> dict:
    return {"type": "array", "items": items or {"type": "number"}, "minItems": length, "maxItems": length,
            "description": doc}


_POSE = _vector(6, "[x, y, z, rx, ry, rz] in the robot base frame (m, rotation vector in rad)")
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
DOCUMENT_SCHEMA = {
    "type": "object", "additionalProperties": False, "required": ["nodes", "edges"],
    "properties": {
        "directed": {"const": True}, "multigraph": {"const": False},
        "graph": {"type": "object", "additionalProperties": False,
                  "properties": {"name": {"type": "string"}, "units": {"const": "m"}, "doc": {"type": "string"}}},
        "nodes": {"type": "array", "items": {"type": "object"}}, "edges": {"type": "array", "items": {"type": "object"}},
    },
}
WAIT = "<wait>"  # what a dispatcher answers while no element may be built yet (not a valid element id here)
_JSON_TYPES = {"string": str, "array": list, "object": dict, "boolean": bool, "null": type(None)}


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


def schema_problem(value: Any, schema: dict) -> str | None:
    """Why `value` does not match `schema` (the subset of JSON Schema used above), or None.
    Numbers must be finite: NaN and infinity never match "number"."""
    if "anyOf" in schema:
        problems = [schema_problem(value, option) for option in schema["anyOf"]]
        return None if None in problems else " or ".join(p for p in problems if p)
    if "const" in schema and (value != schema["const"] or type(value) is not type(schema["const"])):
        return f"must be {json.dumps(schema['const'])}, got {_short(value)}"
    if "enum" in schema and (not isinstance(value, str) or value not in schema["enum"]):
        return f"must be one of {', '.join(schema['enum'])}, got {_short(value)}" + (
            f" ({did_you_mean(value, schema['enum'])})" if did_you_mean(value, schema["enum"]) else "")
    types = schema.get("type")
    if types is not None:
        types = [types] if isinstance(types, str) else types
        if not any(_is(value, t) for t in types):
            return f"must be {' or '.join(types)}" + (" (finite)" if "number" in types else "") + f", got {_short(value)}"
    if _is(value, "number") and "exclusiveMinimum" in schema and not value > schema["exclusiveMinimum"]:
        return f"must be above {schema['exclusiveMinimum']}, got {value}"
    if isinstance(value, dict) and "properties" in schema:
        return next((f"{message}" + (f" ({hint})" if hint else "") for message, _, hint in
                     _object_problems(value, schema, "")), None)
    if isinstance(value, list):
        if not schema.get("minItems", 0) <= len(value) <= schema.get("maxItems", len(value)):
            return f"must be a list of {schema['minItems']} numbers, got {_short(value)}"
        for i, item in enumerate(value):
            problem = schema_problem(item, schema.get("items", {}))
            if problem:
                return f"item {i} {problem}"
    return None


def _is(value: Any, json_type: str) -> bool:
    if json_type == "number":
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    return isinstance(value, _JSON_TYPES[json_type]) and (json_type == "boolean" or not isinstance(value, bool))


def _short(value: Any) -> str:
    text = json.dumps(value, default=str) if not isinstance(value, float) or math.isfinite(value) else str(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _object_problems(obj: dict, schema: dict, what: str) -> Iterator[tuple[str, str | None, str | None]]:
    """(message, field, hint) for each way a JSON object breaks its object schema."""
    known = schema["properties"]
    for key in obj:
        if key not in known:
            yield f"{what}: unknown field {key!r}", key, did_you_mean(key, known) or f"known: {', '.join(known)}"
    for key in schema.get("required", ()):
        if key not in obj:
            yield f"{what}: missing field {key!r}", None, None
    for key, value in obj.items():
        problem = schema_problem(value, known[key]) if key in known else None
        if problem:
            yield f"{what}: field {key!r} {problem}", key, None


def node_problems(node: dict) -> list[tuple[str, str | None, str | None]]:
    """(message, field, hint) for each way a design node (with its id and kind) breaks its schema."""
    kind = node.get("kind")
    if kind not in NODE_SCHEMAS:
        return [(f"node {node.get('id')!r}: kind must be 'element' or 'plate', got {_short(kind)}", "kind",
                 did_you_mean(kind, NODE_SCHEMAS))]
    return list(_object_problems(node, NODE_SCHEMAS[kind], f"{kind} {node.get('id')!r}"))


def _read_json(path: Path) -> Any:
    """The JSON document at `path` with every object a `Located` (the line it starts on and the
    line of each key); a located TreeError for malformed JSON, duplicate keys or deep nesting."""
    text = read_text(path)
    decoder = json.JSONDecoder()

    def parse_object(s_and_end: tuple[str, int], *args: Any) -> tuple[Located, int]:
        s, start = s_and_end
        pairs, end = json.decoder.JSONObject(s_and_end, decoder.strict, decoder.scan_once, None, list, memo)
        out = Located()
        out.file, out.line, out.key_lines = str(path), s.count("\n", 0, start) + 1, {}
        cursor = start
        for key, value in pairs:  # in order: each key is found after the one before
            at = s.find(json.dumps(key), cursor, end)
            cursor = max(cursor, at + 1)
            line = s.count("\n", 0, at) + 1 if at >= 0 else out.line
            if key in out:
                raise TreeError(f"duplicate key {key!r}", str(path), line)
            out[key], out.key_lines[key] = value, line
        return out, end

    memo: dict = {}
    decoder.parse_object = parse_object
    decoder.scan_once = json.scanner.py_make_scanner(decoder)  # the Python scanner calls parse_object
    try:
        return decoder.decode(text)
    except json.JSONDecodeError as exc:
        raise TreeError(f"malformed JSON: {exc.msg}", str(path), exc.lineno) from None
    except RecursionError:
        raise TreeError("malformed JSON: nested too deeply", str(path)) from None


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
        data = _read_json(path)
        if isinstance(data, dict) and "links" in data and "edges" not in data:
            raise TreeError("edges are under 'links' (networkx < 3.6 default); rename the key to 'edges'",
                            str(path), data.line_of("links"))
        if not isinstance(data, dict):
            raise TreeError("not a node-link graph: a JSON object with 'nodes' and 'edges'", str(path), 1)
        for message, key, hint in _object_problems(data, DOCUMENT_SCHEMA, "design"):
            raise TreeError(message, str(path), data.line_of(key), hint=hint)
        lines = {}
        for node in data["nodes"]:
            if not isinstance(node.get("id"), str) or node["id"] in lines:
                what = "a string id" if not isinstance(node.get("id"), str) else f"a unique id ({node['id']!r} twice)"
                raise TreeError(f"every node needs {what}", str(path), node.line_of("id"))
            lines[node["id"]] = node.line
        for i, edge in enumerate(data["edges"]):
            for message, key, hint in _object_problems(edge, EDGE_SCHEMA, f"edge {i}"):
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


class DesignBridge:
    """Sends as-built data back to the design model. Each record (`placing` before the fingers
    open, `placed` once the element stands, a person's `marked`) is first appended to the event
    log and forced to disk, then the as-built model file is replaced atomically: a crash or a
    failed write between the two loses nothing, and `catch_up` replays the log on resume.

    `links` (live design links, e.g. `assembly.design_link.mqtt_bridge.MqttLink`) see every event
    after it is logged (`on_event(record, model)`), and hand in design changes at element
    boundaries (`apply_pending(model) -> changed ids`); the file stays the record of truth."""

    RECORDS = ("placing", "placed", "marked")  # events that change an element's status

    def __init__(self, model: DesignModel, asbuilt_path: Path, events_path: Path, links: tuple = (),
                 dispatcher: Any = None):
        self.model = model
        self.asbuilt_path = Path(asbuilt_path)
        self.events_path = Path(events_path)
        self.links = list(links)
        self.dispatcher = dispatcher  # hands out the next element when several cells share a design
        atomic_write_json(self.asbuilt_path, model.to_data())

    def next_element(self, remaining: list[str]) -> str | None:
        """The element to build next: the first one left, or the dispatcher's choice (None: all
        done; WAIT: not yet, ask again next tick)."""
        if self.dispatcher is not None:
            return self.dispatcher.next_element(remaining, self.model)
        return remaining[0] if remaining else None

    def event(self, kind: str, **data: Any) -> bool:
        """Log an event (to stderr if the log cannot be written) and show it to the links; whether
        it reached the log."""
        record = {"time": time.time(), "event": kind, **data}
        logged = append_json_line_or_stderr(self.events_path, record)
        self.notify(record)
        return logged

    def notify(self, record: dict) -> None:
        """Show a record to the live links only (a passing state such as `picking`, not logged)."""
        for link in self.links:
            link.on_event(record, self.model)

    def at_boundary(self) -> list[str]:
        """Between two elements: apply the design changes the links received (each link checks
        them against the model and reports what it refuses), log them and save the model; the
        elements changed, in order."""
        changed: list[str] = []
        for link in self.links:
            changed += link.apply_pending(self.model)
        if changed:
            self.event("design_updated", elements=changed)
            atomic_write_json(self.asbuilt_path, self.model.to_data())
        return changed

    def close(self) -> None:
        """Close the links (each sends what it still holds first, within its own time limit)."""
        for link in self.links:
            link.close()

    def record_placing(self, eid: str, pose, load: float | None) -> None:
        """The element is about to be released at `pose`: a resumed run must not pick it again."""
        self._record("placing", eid, pose, load)

    def record_placement(self, eid: str, pose, load: float | None) -> None:
        """The element stands at `pose` carrying `load`."""
        self._record("placed", eid, pose, load)

    def mark(self, eid: str, status: str) -> None:
        """A person's verdict on an element left `placing`: `placed` (it stands where recorded)
        or `planned` (build it again)."""
        node = self.model.graph.nodes[eid]
        self._record("marked", eid, node.get("asbuilt_pose"), node.get("measured_load"), status)

    def _record(self, kind: str, eid: str, pose, load: float | None, status: str | None = None) -> None:
        data = {"element": eid, "status": status or kind,
                "pose": None if pose is None else np.asarray(pose, float).round(6).tolist(),
                "load": None if load is None else round(float(load), 6)}
        self._apply(data)
        logged = self.event(kind, **data)
        try:
            atomic_write_json(self.asbuilt_path, self.model.to_data())
        except OSError as exc:
            kept = self.events_path if logged else "stderr"
            raise RuntimeError(f"cannot write the as-built model {self.asbuilt_path} ({exc.strerror or exc}); "
                               f"the {kind} record of {eid} is in {kept}") from exc

    def _apply(self, record: dict) -> None:
        node = self.model.graph.nodes[record["element"]]
        node["status"] = record["status"]
        for name, key in (("asbuilt_pose", "pose"), ("measured_load", "load")):
            if record["status"] == "planned":
                node.pop(name, None)
            else:
                node[name] = record[key]

    def catch_up(self) -> list[str]:
        """Replay the event log's records onto the model (those a failed or interrupted model
        write missed), save it if anything changed, and return the elements changed."""
        changed = []
        for record in read_json_lines(self.events_path):
            if record.get("event") in self.RECORDS and record.get("element") in self.model.graph:
                node = self.model.graph.nodes[record["element"]]
                before = (node.get("status"), node.get("asbuilt_pose"), node.get("measured_load"))
                self._apply(record)
                if (node.get("status"), node.get("asbuilt_pose"), node.get("measured_load")) != before:
                    changed.append(record["element"])
        if changed:
            atomic_write_json(self.asbuilt_path, self.model.to_data())
        return changed
