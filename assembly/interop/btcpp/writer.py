"""Export a tree file as BehaviorTree.CPP v4 XML (the mapping of each kind: docs/btcpp.md).

The exporter reads the tree as written, not as expanded: each subtree becomes a `<BehaviorTree>`
whose `$param`s are port references `{param}`, and each instance a `<SubTree>` with its params as
ports, every param the instance leaves to its default written out too (BT.CPP has no other place
for it that its XSD allows), named in the instance's `_fvtree_defaults` attribute so that the
importer leaves them out again. What BT.CPP's XML cannot hold (the cell settings, the design
model, the subtrees' typed param declarations) travels in an `<!-- fvtree {json} -->` comment,
the first thing inside `<root>`, which BT.CPP (tinyxml2), Groot2 and XSD validation skip. A guard
is a `ReactiveSequence` of its condition (named `GUARD.while`, the mark the importer reads) and its
child, which fails as ours does when the condition is false (BT.CPP's `_while` would skip it).
"""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from assembly.errors import TreeError, TreeErrors
from assembly.interop.btcpp.nodes_model import tree_nodes_model
from assembly.interop.btcpp.values import PortError, condition_script, to_port
from assembly.language.kinds import NODE_KINDS
from assembly.language.reader import load_tree
from behaviours.skill_kit.base import Param
from behaviours.skill_kit.model_files import UsesModel
from behaviours.skill_kit.registry import SKILLS
from fvfiles.yaml_source import Located, load_file

META_TAG = "fvtree"  # the metadata comment is `<!-- fvtree {json} -->`
DEFAULTS_ATTR = "_fvtree_defaults"  # SubTree ports written only because the param has a default
GUARD_MARK = ".while"  # a guard is a ReactiveSequence NAME whose first child, its condition, is named NAME.while
MEMORY_TAGS = {("sequence", True): "Sequence", ("sequence", False): "ReactiveSequence",
               ("selector", True): "Fallback", ("selector", False): "ReactiveFallback"}
# (policy, synchronise) of the parallels BT.CPP's Parallel spells: -> (success_count, failure_count)
PARALLEL_COUNTS = {("all", True): ("-1", "1"), ("one", False): ("1", "1")}
STATUS_MAP_TAGS = {(("failure", "success"),): "ForceSuccess", (("success", "failure"),): "ForceFailure"}


class _Writer:
    """Turns raw (validated) YAML nodes into BT.CPP elements, raising a located TreeError for
    what has no spelling."""

    def __init__(self, file: str, out_dir: Path, subtrees: dict[str, dict[str, Param]]):
        self.file, self.out_dir, self.subtrees = file, out_dir, subtrees

    def refuse(self, node: Located, path: str, message: str, hint: str | None = None) -> TreeError:
        return TreeError(f"cannot export: {message}", getattr(node, "file", self.file), getattr(node, "line", None),
                         path, hint)

    def port(self, node: Located, path: str, value: Any, field: str) -> str:
        try:
            return to_port(value)
        except PortError as exc:
            raise self.refuse(node, path, f"{field}: {exc}") from None

    def node(self, node: Located, parent: str) -> ET.Element:
        kind = next(k for k in node if k in NODE_KINDS)
        value = node[kind]
        name = node.get("name", value) if NODE_KINDS[kind].typed else value
        path = f"{parent}/{name}" if parent else name
        write = getattr(self, f"_{kind}", None)
        if write is None:
            raise self.refuse(node, path, f"the node kind {kind!r} has no BT.CPP mapping",
                              "add one to assembly/interop/btcpp/writer.py and reader.py")
        element = write(node, path, name)
        children = [node["child"]] if "child" in node else node.get("children", []) if kind != "subtree" else []
        for child in children:
            element.append(self.node(child, path))
        return element

    def _element(self, tag: str, name: str, **ports: str) -> ET.Element:
        return ET.Element(tag, {"name": name, **ports})

    def _composite(self, node, path, name):
        memory = node["memory"]
        kind = "sequence" if "sequence" in node else "selector"
        if not isinstance(memory, bool):
            raise self.refuse(node, path, "'memory' from a $param: the BT.CPP node type depends on it",
                              "write memory: true or false")
        return self._element(MEMORY_TAGS[kind, memory], name)

    _sequence = _selector = _composite

    def _parallel(self, node, path, name):
        policy, sync = node["policy"], node.get("synchronise", False)
        counts = PARALLEL_COUNTS.get((policy, sync)) if isinstance(sync, bool) else None
        if counts is not None:
            return self._element("Parallel", name, success_count=counts[0], failure_count=counts[1])
        ports = {"policy": self.port(node, path, policy, "policy"),
                 "synchronise": self.port(node, path, sync, "synchronise")}
        if "selected" in node:
            ports["selected"] = ";".join(str(s) for s in node["selected"])
        return self._element("FvParallel", name, **ports)

    def _retry(self, node, path, name):
        return self._element("RetryUntilSuccessful", name, num_attempts=self.port(node, path, node["attempts"],
                                                                                   "attempts"))

    def _repeat(self, node, path, name):
        return self._element("Repeat", name, num_cycles=self.port(node, path, node["times"], "times"))

    def _timeout(self, node, path, name):
        seconds = node["seconds"]
        msec = seconds * 1000 if isinstance(seconds, (int, float)) else None
        if msec is None or msec != round(msec):
            raise self.refuse(node, path, f"'seconds: {seconds}' is not a whole number of milliseconds",
                              "BT.CPP's Timeout takes msec as an integer")
        return self._element("Timeout", name, msec=str(round(msec)))

    def _inverter(self, node, path, name):
        return self._element("Inverter", name)

    def _status_map(self, node, path, name):
        pairs = tuple(sorted(node["map"].items()))
        tag = STATUS_MAP_TAGS.get(pairs)
        if tag:
            return self._element(tag, name)
        return self._element("StatusMap", name, map=";".join(f"{k}:{v}" for k, v in pairs))

    def _guard(self, node, path, name):
        # BT.CPP's own `_while` would make a false guard SKIPPED (its parent goes on): a reactive
        # sequence of the condition and the child fails instead, re-checking it every tick, as ours
        element = self._element("ReactiveSequence", name)
        element.append(self._check(node["while"], guard_condition_name(name)))
        return element

    def _for_each_element(self, node, path, name):
        element = self._element("ForEachElement", name)
        if node.get("elements") == []:
            raise self.refuse(node, path, "'elements: []': an empty port means elements left out (every element)",
                              "leave 'elements' out, or drop the node: it would build nothing")
        if "elements" in node:
            element.set("elements", ";".join(node["elements"]))
        return element

    def _condition(self, node, path, name):
        return self._check(node, name)

    def _check(self, cond: Located, name: str) -> ET.Element:
        """A `{key, op, value}` condition: a ScriptCondition, or a BlackboardCheck where a script cannot say it."""
        script = condition_script(str(cond["key"]), cond["op"], cond.get("value"))
        if script is not None:
            return self._element("ScriptCondition", name, code=script)
        ports = {"key": str(cond["key"]), "op": cond["op"]}
        if "value" in cond:
            ports["value"] = json.dumps(cond["value"])
        return self._element("BlackboardCheck", name, **ports)

    def _params(self, node, path) -> dict[str, str]:
        return {k: self.port(node, path, v, f"param {k!r}") for k, v in (node.get("params") or {}).items()}

    def _skill(self, node, path, name):
        ports = self._params(node, path)
        model = (node.get("params") or {}).get("model")
        if issubclass(SKILLS[node["skill"]], UsesModel) and isinstance(model, str) and not model.startswith("$"):
            ports["model"] = rebase(model, Path(node.file).parent, self.out_dir)
        return self._element(node["skill"], name, **ports)

    def _subtree(self, node, path, name):
        ports = self._params(node, path)
        defaults = {p: self.port(node, path, d.default, f"default of {p!r}")
                    for p, d in self.subtrees[node["subtree"]].items() if p not in ports and not d.required}
        element = ET.Element("SubTree", {"ID": node["subtree"], "name": name, **ports, **defaults})
        if defaults:
            element.set(DEFAULTS_ATTR, ";".join(defaults))
        return element


def guard_condition_name(guard: str) -> str:
    """The name of a guard's condition node in BT.CPP (the mark the importer reads a guard by)."""
    return guard + GUARD_MARK


def _param_decl(p: Param) -> dict:
    out: dict[str, Any] = {"type": p.type}
    if not p.required:
        out["default"] = p.default
    if p.unit:
        out["unit"] = p.unit
    if p.doc:
        out["doc"] = p.doc
    return out


def comment_safe(text: str) -> str:
    """JSON text that can stand in an XML comment: no `--` (JSON reads `\\u002d` back as `-`)."""
    return text.replace("--", "-\\u002d")


def rebase(path: str, from_dir: Path, to_dir: Path) -> str:
    """A relative `path` written in `from_dir`, written instead in `to_dir` (absolute ones stay)."""
    if Path(path).expanduser().is_absolute():
        return path
    return os.path.relpath((from_dir / path).resolve(), to_dir.resolve())


def export_tree(path: str | Path, out_dir: str | Path = ".", subtree_models: bool = False) -> str:
    """The BT.CPP v4 XML of a tree file (validated first) to be written in `out_dir` (file paths
    such as the design and model files are made relative to it); TreeErrors for what has no spelling.
    `subtree_models` adds Groot2's `<SubTree>` port declarations (outside BT.CPP's XSD)."""
    doc = load_tree(path)
    raw = load_file(path)
    out_dir = Path(out_dir)
    writer = _Writer(str(path), out_dir, {name: sub.params for name, sub in doc.subtrees.items()})
    main_id = doc.name
    if main_id in doc.subtrees:
        raise TreeErrors([TreeError(f"cannot export: the tree's name {main_id!r} is also a subtree's",
                                    str(path), raw.line_of("name"), hint="rename the tree or the subtree")])
    meta = {"version": 1, "name": doc.name, **{k: raw[k] for k in ("doc", "cell") if k in raw},
            "subtrees": {name: {"params": {p: _param_decl(d) for p, d in sub.params.items()}}
                         for name, sub in doc.subtrees.items()}}
    if "design" in raw:
        meta["design"] = rebase(raw["design"], Path(path).parent, out_dir)
    root = ET.Element("root", {"BTCPP_format": "4", "main_tree_to_execute": main_id})
    root.append(ET.Comment(f" {META_TAG} {comment_safe(json.dumps(meta))} "))
    try:
        trees = [(main_id, writer.node(raw["root"], ""))]
        trees += [(name, writer.node(sub.root, "")) for name, sub in doc.subtrees.items()]
    except TreeError as exc:
        raise TreeErrors([exc]) from None
    for tree_id, body in trees:
        ET.SubElement(root, "BehaviorTree", {"ID": tree_id}).append(body)
    root.append(tree_nodes_model({n: sub.params for n, sub in doc.subtrees.items()} if subtree_models else None))
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
