"""The `<TreeNodesModel>` of an exported tree: every skill as an Action with its params as typed
input ports (default, unit, range and meaning in the port's text), and the custom nodes that carry
our own kinds, so Groot2 shows every node in its palette with its ports.

BT.CPP makes a port without a default mandatory (its generated XSD says `use="required"`), so an
optional param without a default (`move_to.pose`) is declared with the empty default: an empty port
is a param left out, both ways."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from assembly.interop.btcpp.values import to_port
from behaviours.skill_kit.base import Param
from behaviours.skill_kit.registry import SKILLS

PORT_TYPES = {"float": "double", "int": "int", "bool": "bool", "str": "std::string", "vector": "std::vector<double>"}

NOT_GIVEN = ""  # the default of an optional port without one: the param is left out
# Our kinds without a BT.CPP built-in: ID -> (model element, {port: (type, text, default)}, description);
# a default of None makes the port mandatory.
CUSTOM_NODES: dict[str, tuple[str, dict[str, tuple[str, str, str | None]], str]] = {
    "ForEachElement": (
        "Decorator",
        {"elements": ("std::vector<std::string>",
                      "element ids to build, ';'-separated (all unplaced elements of the design when empty)",
                      NOT_GIVEN)},
        "fvtree for_each_element: the child once per unplaced design element, in build order, on /task/element"),
    "StatusMap": (
        "Decorator", {"map": ("std::string", "status pairs 'from:to;...' of success, failure, running", None)},
        "fvtree status_map: returns the child's status translated through the map"),
    "FvParallel": (
        "Control",
        {"policy": ("std::string", "all, one or selected", None),
         "synchronise": ("bool", "children that succeeded are not ticked again", "false"),
         "selected": ("std::vector<std::string>", "with policy selected: the children whose success counts",
                      NOT_GIVEN)},
        "fvtree parallel with a policy BT.CPP's Parallel cannot spell"),
    "BlackboardCheck": (
        "Condition",
        {"key": ("std::string", "blackboard key, e.g. /fv/left.slip", None),
         "op": ("std::string", "eq, ne, lt, le, gt, ge or exists", None),
         "value": ("std::string", "JSON value to compare with (empty with exists)", NOT_GIVEN)},
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
    # An optional number without a default (e.g. taken from the cell's sensor profile when left out)
    # is declared as text: "" (not given) is no valid double or int for BT.CPP's XSD.
    unset_number = p.default is None and not p.required and p.type in ("float", "int")
    attrs = {"name": name, "type": "std::string" if unset_number else PORT_TYPES[p.type]}
    if not p.required:
        attrs["default"] = NOT_GIVEN if p.default is None else to_port(p.default)
    ET.SubElement(node, "input_port", attrs).text = _port_text(p) + (" (empty: not given)" if p.default is None
                                                                      and not p.required else "")


def tree_nodes_model(subtrees: dict[str, dict[str, Param]] | None = None) -> ET.Element:
    """`<TreeNodesModel>` with every skill and every custom node; with `subtrees` (name -> params)
    also Groot2's `<SubTree ID=... editable="true">` entries declaring the subtrees' ports, which
    Groot2 reads but BT.CPP's XSD does not allow."""
    model = ET.Element("TreeNodesModel")
    for name in sorted(SKILLS):
        model.append(skill_model(name))
    for node_id, (element, ports, doc) in CUSTOM_NODES.items():
        node = ET.SubElement(model, element, {"ID": node_id})
        for pname, (ptype, text, default) in ports.items():
            attrs = {"name": pname, "type": ptype, **({} if default is None else {"default": default})}
            ET.SubElement(node, "input_port", attrs).text = text
        ET.SubElement(node, "description").text = doc
    for name, params in (subtrees or {}).items():
        node = ET.SubElement(model, "SubTree", {"ID": name, "editable": "true"})
        for pname, p in params.items():
            _port(node, pname, p)
    return model
