"""The design model as COMPAS data: a `compas.datastructures.Graph` that `compas.json_load` opens
without this package, converted both ways from the node-link design (`assembly.design.model`).

Why a Graph: it is COMPAS core (no compas_assembly or compas_timber needed), its node keys are our
element and plate ids, its edges keep their direction (u -> v: u stands before v), and node
attributes may hold COMPAS geometry (frames, boxes), which Rhino, Grasshopper and compas_viewer
draw. `compas.datastructures.Assembly` keys parts by integers under Part objects, so the ids and the
precedence would have to be rebuilt from attributes.

Conventions: metres, kilograms, newtons; every frame is in the robot base frame. An element's frame
has its origin at the element's centre, x along its length, y across its width (the fingers close
along y) and z along its depth; the node-link pose [x, y, z, rx, ry, rz] is that frame's origin and
the rotation vector of its axes. A plate's frame has its origin at the left support on the soffit
and x along the span. Element node attributes: kind, plate, size [length, width, depth], mass,
status (a live plan also shows picking and failed, read back as planned), pick_frame,
planned_frame, asbuilt_frame, measured_load (N), cell (who placed it), and, for display only,
`box` (at the as-built frame, else the planned one, else the pick one) and x, y, z (its centre).
Plate node attributes: kind, frame, span, width, and for display `box` (PLATE_THICKNESS thick,
above the soffit) and x, y, z.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import compas
import networkx as nx
import numpy as np
from compas.datastructures import Graph
from compas.geometry import Box, Frame
from scipy.spatial.transform import Rotation

from assembly.design.model import DesignModel
from assembly.errors import TreeError
from fvfiles.schema_check import schema_problem

FORMAT = "fvtree.design/1"  # graph attribute naming this layout, checked on load
PLATE_THICKNESS = 0.02  # m, only for drawing: the design holds the soffit, not the thickness
POSE_FIELDS = {"pick_pose": "pick_frame", "planned_pose": "planned_frame", "asbuilt_pose": "asbuilt_frame"}
DIGITS = 9  # poses read back from frames are rounded to this many decimals (nm, nrad)
LIVE_STATUSES = ("picking", "failed")  # shown on a live plan (design_link.mqtt_bridge) besides STATUSES


def pose_to_frame(pose) -> Frame:
    """The frame of a pose [x, y, z, rx, ry, rz] (m, rotation vector in rad)."""
    pose = np.asarray(pose, float)
    axes = Rotation.from_rotvec(pose[3:]).as_matrix()
    return Frame(pose[:3].tolist(), axes[:, 0].tolist(), axes[:, 1].tolist())


def frame_to_pose(frame: Frame) -> list[float]:
    """The pose [x, y, z, rx, ry, rz] of a frame, rounded to DIGITS decimals."""
    axes = np.column_stack([list(frame.xaxis), list(frame.yaxis), list(frame.zaxis)])
    rotvec = Rotation.from_matrix(axes).as_rotvec()
    return [round(float(v), DIGITS) + 0.0 for v in [*frame.point, *rotvec]]


def _display_box(frame: Frame, size, offset=(0.0, 0.0, 0.0)) -> Box:
    centre = Frame(frame.to_world_coordinates(list(offset)), frame.xaxis, frame.yaxis)
    return Box(*[float(s) for s in size], frame=centre)


def to_graph(model: DesignModel) -> Graph:
    """The design (or as-built model) as a COMPAS Graph (see the module docstring)."""
    data = model.to_data()
    graph = Graph(name=data.get("graph", {}).get("name"))
    graph.attributes.update({k: v for k, v in data.get("graph", {}).items() if k != "name"})
    graph.attributes.update(format=FORMAT, units="m")
    for node in data["nodes"]:
        attrs = {k: v for k, v in node.items() if k != "id"}
        if attrs["kind"] == "element":
            for pose_key, frame_key in POSE_FIELDS.items():
                if pose_key in attrs:
                    pose = attrs.pop(pose_key)
                    attrs[frame_key] = None if pose is None else pose_to_frame(pose)
            shown = attrs.get("asbuilt_frame") or attrs.get("planned_frame") or attrs["pick_frame"]
            attrs["box"] = _display_box(shown, attrs["size"])
        else:
            frame = Frame(attrs.pop("origin"), [1, 0, 0], [0, 1, 0])
            attrs["frame"] = frame
            attrs["box"] = _display_box(frame, (attrs["span"], attrs["width"], PLATE_THICKNESS),
                                        (attrs["span"] / 2, 0.0, PLATE_THICKNESS / 2))
        x, y, z = attrs["box"].frame.point
        graph.add_node(node["id"], x=x, y=y, z=z, **attrs)
    for edge in data["edges"]:
        graph.add_edge(edge["source"], edge["target"])
    return graph


def _not_a_frame(key: str, name: str, value: Any, source: str) -> TreeError:
    return TreeError(f"node {key!r}: field {name!r} must be a compas.geometry Frame, got {type(value).__name__}",
                     source, hint="send the frame, or a 6-list pose")


def node_from_graph(key: str, attrs: dict, source: str = "<graph>") -> dict:
    """The node-link node of one Graph node: frames back to poses, display attributes dropped."""
    node: dict[str, Any] = {"id": key}
    for name, value in attrs.items():
        if name in ("box", "x", "y", "z"):
            continue
        if name == "frame":
            if not isinstance(value, Frame):
                raise _not_a_frame(key, name, value, source)
            node["origin"] = [round(float(v), DIGITS) + 0.0 for v in value.point]
        elif name in POSE_FIELDS.values():
            if value is not None and not isinstance(value, Frame):
                raise _not_a_frame(key, name, value, source)
            pose_key = next(k for k, f in POSE_FIELDS.items() if f == name)
            node[pose_key] = None if value is None else frame_to_pose(value)
        elif name == "status" and value in LIVE_STATUSES:
            node[name] = "planned"  # a passing state of a live plan: not built, so planned
        else:
            node[name] = value
    return node


def from_graph(graph: Graph, source: str | Path | None = None) -> DesignModel:
    """The design model of a COMPAS Graph written by `to_graph` (checked like a design file;
    `source`, the file it came from, names it in errors)."""
    where = str(source) if source is not None else "<graph>"
    if not isinstance(graph, Graph):
        raise TreeError(f"not a COMPAS design graph: got {type(graph).__name__}", where,
                        hint="save one with `fvtree design export` or assembly.design.link.compas_data.to_graph")
    attributes = dict(graph.attributes)
    if attributes.pop("format", None) != FORMAT:
        raise TreeError(f"graph attribute 'format' must be {FORMAT!r}", where,
                        hint="this graph was not written by fvtree; see the conventions in the README")
    nodes = [node_from_graph(key, attrs, where) for key, attrs in graph.nodes(data=True)]
    edges = [{"source": u, "target": v} for u, v in graph.edges()]
    header = {k: v for k, v in attributes.items() if k in ("units", "doc")}
    if graph.name and graph.name != "Graph":
        header["name"] = graph.name
    data = {"directed": True, "multigraph": False, "graph": header, "nodes": nodes, "edges": edges}
    for i, edge in enumerate(edges):
        for end in ("source", "target"):
            problem = schema_problem(edge[end], {"type": "string"})
            if problem or edge[end] not in graph.node:
                raise TreeError(f"edge {i} {end} {edge[end]!r} is not a node", where)
    return DesignModel(nx.DiGraph(nx.node_link_graph(data, directed=True, edges="edges")), source)


def save_compas(model: DesignModel, path: str | Path) -> Path:
    """Write the design as COMPAS JSON (`compas.json_load(path)` gives the Graph back)."""
    path = Path(path)
    compas.json_dump(to_graph(model), str(path), pretty=True)
    return path


def load_compas(path: str | Path) -> DesignModel:
    """Read a design saved by `save_compas` (or edited in COMPAS) and check it like a design file."""
    path = Path(path)
    try:
        graph = compas.json_load(str(path))
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise TreeError(f"not COMPAS JSON: {exc}", str(path), hint="write it with compas.json_dump") from None
    return from_graph(graph, path)
