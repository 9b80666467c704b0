"""The running tree as Groot2's `FULLTREE` reply: BT.CPP XML with `_uid` and `_fullpath` on every node.

BT.CPP's publisher sends the tree as created: every subtree instance a `<BehaviorTree>` of its own
(in the order the instances are met, depth first) whose `_fullpath` is the instance's path (the
names of the subtree instances it is in, joined by `/`), the `<SubTree>` node pointing at it by ID.
Groot2 (and btview) expand each `<SubTree>` from the next block of its ID. Here each node's element
comes from the project's BT.CPP export (`assembly.interop.btcpp.export_tree`, so Groot2 sees the
same tags and ports as in an exported file), walked beside the validated tree the run ticks; each
node gets its `_uid` as BT.CPP numbers them (from 1, depth first, a subtree's nodes where it is
instantiated) and its BT.CPP `fullPath()` as `_fullpath` (BT.CPP writes that only on `<SubTree>`
nodes; tests/test_groot2.py compares the whole with what BT.CPP itself writes for the same file).
A node a `--substitute` rule replaced is a `TestDouble` action saying what it stands for.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from assembly.interop.btcpp import export_tree
from assembly.interop.btcpp.values import PortError, literal
from assembly.language.reader import TreeDocument
from assembly.language.validator import NodeSpec

DOUBLE_TAG = "TestDouble"
DOUBLE_KINDS = {"status_double", "skill_double"}
NOT_PORTS = {"ID", "name", "_uid", "_fullpath", "_fvtree_defaults"}


@dataclass
class MonitorTree:
    """The XML Groot2 is sent, each node's uid by its fvtree path, and each subtree instance's ports
    (what BT.CPP keeps on a subtree's own blackboard) by its BT.CPP instance path."""

    xml: str
    uids: dict[str, int]  # node path -> uid
    main_id: str
    subtree_ports: dict[str, dict[str, object]] = field(default_factory=dict)


def monitor_tree(doc: TreeDocument) -> MonitorTree:
    """The `FULLTREE` XML of a validated tree file (the run's document, doubles and all);
    TreeErrors from the export for a node BT.CPP's XML cannot spell."""
    exported = ET.fromstring(export_tree(doc.path, Path(doc.path).parent))
    blocks = {b.get("ID", ""): b for b in exported.findall("BehaviorTree")}
    main_id = exported.get("main_tree_to_execute", doc.name)
    out = ET.Element("root", {"BTCPP_format": "4", "main_tree_to_execute": main_id})
    main = ET.SubElement(out, "BehaviorTree", {"ID": main_id, "_fullpath": ""})
    walk = _Walk(blocks, out)
    main.append(walk.node(doc.root, _body(blocks[main_id]), ""))
    model = exported.find("TreeNodesModel")
    if model is None:
        model = ET.Element("TreeNodesModel")
    _declare_doubles(model, walk.doubles)
    out.append(model)
    ET.indent(out, space="  ")
    return MonitorTree(ET.tostring(out, encoding="unicode"), walk.uids, main_id, walk.subtree_ports)


class _Walk:
    """Pairs each validated node with its exported element, numbering them depth first."""

    def __init__(self, blocks: dict[str, ET.Element], root: ET.Element):
        self.blocks, self.root = blocks, root
        self.uids: dict[str, int] = {}
        self.subtree_ports: dict[str, dict[str, object]] = {}
        self.doubles: set[str] = set()
        self.count = 0  # uids given (a guard's condition has one, but no fvtree node)

    def node(self, spec: NodeSpec, exported: ET.Element, instance: str) -> ET.Element:
        """The element of `spec` (and below), inside the subtree instance of path `instance`."""
        # A new element (not a copy, which would share its attributes with the other instances of a
        # subtree); children are added below, from the validated tree.
        element = self._double(spec) if spec.kind in DOUBLE_KINDS else ET.Element(exported.tag, exported.attrib)
        element.attrib.pop("_fvtree_defaults", None)
        self.uids[spec.path] = self._number(element, spec.name, instance)
        prefix = f"{instance}/" if instance else ""
        if spec.kind == "subtree":
            inner = prefix + spec.name  # BT.CPP's subtree instance path, the name of its blackboard
            self.subtree_ports[inner] = {k: _value(v) for k, v in exported.attrib.items() if k not in NOT_PORTS}
            block = ET.SubElement(self.root, "BehaviorTree", {"ID": spec.type, "_fullpath": inner})
            block.append(self.node(spec.children[0], _body(self.blocks[spec.type]), inner))
            return element
        if spec.kind in DOUBLE_KINDS:
            return element
        kids = list(exported)
        if spec.kind == "guard" and len(kids) == 2:  # a ReactiveSequence: its condition is BT.CPP's node only
            condition = ET.Element(kids[0].tag, kids[0].attrib)
            self._number(condition, kids[0].get("name", kids[0].tag), instance)
            element.append(condition)
            kids = kids[1:]
        if len(kids) != len(spec.children):
            raise ValueError(f"{spec.path}: the export has {len(kids)} children, the tree {len(spec.children)}")
        for child, child_element in zip(spec.children, kids):
            element.append(self.node(child, child_element, instance))
        return element

    def _number(self, element: ET.Element, name: str, instance: str) -> int:
        """Give `element` the next uid and its BT.CPP `fullPath()` (the subtree instance's path, the
        name, and the uid when the name is the node's ID); returns the uid."""
        self.count = uid = self.count + 1
        element.set("_uid", str(uid))
        prefix = f"{instance}/" if instance else ""
        type_id = element.get("ID", "") if element.tag == "SubTree" else element.tag
        element.set("_fullpath", prefix + name + (f"::{uid}" if name == type_id else ""))
        return uid

    def _double(self, spec: NodeSpec) -> ET.Element:
        self.doubles.add(DOUBLE_TAG)
        return ET.Element(DOUBLE_TAG, {"name": spec.name, "note": str(spec.args.get("note", ""))})


def _body(block: ET.Element) -> ET.Element:
    """The root node of an exported `<BehaviorTree>`."""
    return next(iter(block))


def _value(text: str) -> object:
    """A SubTree port's value as BT.CPP's blackboard would show it: a number, bool or text."""
    try:
        value = literal(text)
    except PortError:
        return text
    return text if isinstance(value, str) else value


def _declare_doubles(model: ET.Element, tags: set[str]) -> None:
    for tag in sorted(tags):
        node = ET.SubElement(model, "Action", {"ID": tag})
        ET.SubElement(node, "input_port", {"name": "note", "type": "std::string"}).text = "what the double replaced"
        ET.SubElement(node, "description").text = "fvtree test double (--substitute): a scripted status or skill"
