"""The design model: elements, plates and precedence as a networkx DiGraph in node-link JSON
(`edges="edges"`), its build order, and the bridge that writes as-built data back atomically.

Node kinds (lengths in m, poses [x, y, z, rx, ry, rz] in the robot base frame):
  element: size [length, width, depth], pick_pose, plate (id it props), mass (kg),
           planned_pose (optional), status planned|placed, asbuilt_pose, measured_load
  plate:   origin [x, y, z_soffit] (left support), span, width
An edge u -> v means u must be in place before v. The model holds the design only: what a
simulated cell knows beyond it (the plates' loads) is in the scene file next to it.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

from assembly.errors import TreeError
from assembly.files import append_json_line, atomic_write_json
from perception.errors import did_you_mean

_ELEMENT_FIELDS = {"size": 3, "pick_pose": 6}
_PLATE_FIELDS = {"origin": 3}


class DesignModel:
    """A validated design graph."""

    def __init__(self, graph: nx.DiGraph, path: str | Path | None = None):
        self.graph = graph
        self.path = Path(path) if path is not None else None  # the design file, if loaded from one
        self.source = str(path) if path is not None else "<memory>"
        self._validate()

    @classmethod
    def load(cls, path: str | Path) -> "DesignModel":
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise TreeError("design file not found", str(path)) from None
        except json.JSONDecodeError as exc:
            raise TreeError(f"malformed JSON: {exc.msg}", str(path), exc.lineno) from None
        if not isinstance(data, dict) or "nodes" not in data:
            raise TreeError("not a node-link graph (needs 'nodes' and 'edges')", str(path))
        if "links" in data and "edges" not in data:
            raise TreeError("edges are under 'links' (networkx < 3.6 default); rename the key "
                            "to 'edges'", str(path))
        try:
            graph = nx.node_link_graph(data, directed=True, edges="edges")
        except (KeyError, TypeError, nx.NetworkXError) as exc:
            raise TreeError(f"cannot read the graph: {exc}", str(path)) from None
        return cls(nx.DiGraph(graph), path)

    def to_data(self) -> dict:
        return nx.node_link_data(self.graph, edges="edges")

    def _fail(self, message: str, hint: str | None = None):
        raise TreeError(message, self.source, hint=hint)

    def _validate(self) -> None:
        for node, attrs in self.graph.nodes(data=True):
            kind = attrs.get("kind")
            fields = {"element": _ELEMENT_FIELDS, "plate": _PLATE_FIELDS}.get(kind)
            if fields is None:
                self._fail(f"node {node!r}: kind must be 'element' or 'plate', got {kind!r}")
            for name, length in fields.items():
                value = attrs.get(name)
                if not isinstance(value, list) or len(value) != length:
                    self._fail(f"node {node!r}: field {name!r} must be a list of {length} numbers, "
                               f"got {value!r}")
            if "sim_load" in attrs:
                scene = f"{self.path.stem}.scene.yaml" if self.path else "the scene file next to the design"
                self._fail(f"{kind} {node!r}: field 'sim_load' is simulation data, not design",
                           f"move it to {scene}: 'plates: {{{node}: {{EI: .., w: .., P: .., c: .., k: ..}}}}'")
            if kind == "plate":
                for name in ("span", "width"):
                    if not isinstance(attrs.get(name), (int, float)) or attrs[name] <= 0:
                        self._fail(f"plate {node!r}: field {name!r} must be a positive number")
        plates = self.plates()
        for eid, attrs in self.elements().items():
            if attrs.get("plate") not in plates:
                self._fail(f"element {eid!r} props plate {attrs.get('plate')!r}, which is not in "
                           "the model", did_you_mean(attrs.get("plate"), plates))
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
    """Sends as-built data back to the design model: after each placement the as-built model
    file is replaced atomically and an event is appended (and flushed) to the event log."""

    def __init__(self, model: DesignModel, asbuilt_path: Path, events_path: Path):
        self.model = model
        self.asbuilt_path = Path(asbuilt_path)
        self.events_path = Path(events_path)
        atomic_write_json(self.asbuilt_path, model.to_data())

    def event(self, kind: str, **data: Any) -> None:
        append_json_line(self.events_path, {"time": time.time(), "event": kind, **data})

    def record_placement(self, eid: str, pose, load: float | None, **extra: Any) -> None:
        node = self.model.graph.nodes[eid]
        node.update(status="placed", asbuilt_pose=np.asarray(pose, float).round(6).tolist(),
                    measured_load=None if load is None else round(float(load), 6))
        atomic_write_json(self.asbuilt_path, self.model.to_data())
        self.event("placed", element=eid, pose=node["asbuilt_pose"], load=node["measured_load"], **extra)
