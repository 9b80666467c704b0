"""The `<TreeNodesModel>` of an exported tree: every skill as an Action with its params as typed
input ports (default, unit, range and meaning in the port's text), and the custom nodes that carry
our own kinds, so Groot2 shows every node in its palette with its ports."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from assembly.interop.btcpp.values import to_port
from behaviours.skill_kit.base import Param
from behaviours.skill_kit.registry import SKILLS

PORT_TYPES = {"float": "double", "int": "int", "bool": "bool", "str": "std::string", "vector": "std::vector<double>"}

# Our kinds without a BT.CPP built-in: ID -> (model element, {port: (type, text)}, description).
CUSTOM_NODES: dict[str, tuple[str, dict[str, tuple[str, str]], str]] = {
    "ForEachElement": (
        "Decorator",
        {"elements": ("std::vector<std::string>",
                      "element ids to build, ';'-separated (all unplaced elements of the design when absent)")},
        "fvtree for_each_element: the child once per unplaced design element, in build order, on /task/element"),
    "StatusMap": (
        "Decorator", {"map": ("std::string", "status pairs 'from:to;...' of success, failure, running")},
        "fvtree status_map: returns the child's status translated through the map"),
    "Guard": (
        "Decorator", {},
        "fvtree guard: ticks the child while its _while script holds, halting it and failing when it turns false"),
    "FvParallel": (
        "Control",
        {"policy": ("std::string", "all, one or selected"),
         "synchronise": ("bool", "children that succeeded are not ticked again"),
         "selected": ("std::vector<std::string>", "with policy selected: the children whose success counts")},
        "fvtree parallel with a policy BT.CPP's Parallel cannot spell"),
    "BlackboardCheck": (
        "Condition",
        {"key": ("std::string", "blackboard key, e.g. /fv/left.slip"),
         "op": ("std::string", "eq, ne, lt, le, gt, ge or exists"),
         "value": ("std::string", "JSON value to compare with")},
        "fvtree condition that a BT.CPP script cannot spell (exists, lists)"),
}


def _port_text(p: Param) -> str:
    """What Groot2 shows for a port: the meaning, unit, range and choices."""
    text = p.doc
    if p.unit:
        text += f" [{p.unit}]"
    if p.min is not None or p.max is not None:
        text += f" (range {'' if p.min is None else p.min}..{'' if p.max is None else p.max})"
    if p.choices:
        text += f" (one of {', '.join(map(str, p.choices))})"
    return text


def skill_model(name: str) -> ET.Element:
    """The `<Action ID=skill>` model of one skill."""
    cls = SKILLS[name]
    node = ET.Element("Action", {"ID": name})
    for pname, p in cls.PARAMS.items():
        _port(node, pname, p)
    summary = cls.SUMMARY or (cls.__doc__ or "").strip().splitlines()[0]
    keys = f" Reads {', '.join(cls.READS)}." if cls.READS else ""
    keys += f" Writes {', '.join(cls.WRITES)}." if cls.WRITES else ""
    ET.SubElement(node, "description").text = summary.rstrip(".") + "." + keys
    return node


def _port(node: ET.Element, name: str, p: Param) -> None:
    attrs = {"name": name, "type": PORT_TYPES[p.type]}
    if not p.required and p.default is not None:
        attrs["default"] = to_port(p.default)
    ET.SubElement(node, "input_port", attrs).text = _port_text(p)


def tree_nodes_model(subtrees: dict[str, dict[str, Param]] | None = None) -> ET.Element:
    """`<TreeNodesModel>` with every skill and every custom node; with `subtrees` (name -> params)
    also Groot2's `<SubTree ID=... editable="true">` entries declaring the subtrees' ports, which
    Groot2 reads but BT.CPP's XSD does not allow."""
    model = ET.Element("TreeNodesModel")
    for name in sorted(SKILLS):
        model.append(skill_model(name))
    for node_id, (element, ports, doc) in CUSTOM_NODES.items():
        node = ET.SubElement(model, element, {"ID": node_id})
        for pname, (ptype, text) in ports.items():
            ET.SubElement(node, "input_port", {"name": pname, "type": ptype}).text = text
        ET.SubElement(node, "description").text = doc
    for name, params in (subtrees or {}).items():
        node = ET.SubElement(model, "SubTree", {"ID": name, "editable": "true"})
        for pname, p in params.items():
            _port(node, pname, p)
    return model
