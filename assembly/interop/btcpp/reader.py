"""Import BehaviorTree.CPP v4 XML (as exported, or as Groot2 writes it) into the YAML tree language.

Each BT.CPP node with an equivalent becomes its kind (the table is docs/btcpp.md); anything else
is refused with the XML line and the reason, all problems at once (exit code 2). The result is
validated like any tree file before it is returned.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import yaml

from assembly.errors import TreeError, TreeErrors
from assembly.interop.btcpp.declarations import default_ports, groot_subtree_params, metadata
from assembly.interop.btcpp.nodes_model import NOT_GIVEN
from assembly.interop.btcpp.relocate import node_lines, relocate
from assembly.interop.btcpp.values import (
    PORT_REF,
    PortError,
    from_port,
    key_of_identifier,
    literal,
    read_condition_script,
)
from assembly.interop.btcpp.writer import DEFAULTS_ATTR, guard_condition_name, rebase
from assembly.language.reader import load_tree
from assembly.language.validator import known_blackboard_keys
from behaviours.skill_kit.model_files import UsesModel
from behaviours.skill_kit.registry import SKILLS
from fvfiles.errors import did_you_mean
from fvfiles.xml_source import XmlNode, parse_xml_file

COMPOSITES = {"Sequence": ("sequence", True), "ReactiveSequence": ("sequence", False),
              "Fallback": ("selector", True), "ReactiveFallback": ("selector", False)}
PARALLELS = {("-1", "1"): ("all", True), ("1", "1"): ("one", False)}
COUNTED = {"RetryUntilSuccessful": ("retry", "num_attempts", "attempts"), "Repeat": ("repeat", "num_cycles", "times")}
FORCED = {"ForceSuccess": "failure:success", "ForceFailure": "success:failure"}  # as status_map pairs
LAYOUT_ATTRS = {"_uid", "_fullpath", "_description"}  # Groot2's metadata: `_description` becomes `doc`
NO_EQUIVALENT = {
    "SequenceWithMemory": "after a failure it resumes at the failed child; fvtree sequences start again "
                          "(use Sequence)",
    "AsyncSequence": "it returns RUNNING between children; use Sequence",
    "AsyncFallback": "it returns RUNNING between children; use Fallback",
    "ParallelAll": "its failure threshold has no fvtree parallel policy; use Parallel",
    "Sleep": "it waits on the wall clock; skills wait on the cell clock",
    "Delay": "it waits on the wall clock; skills wait on the cell clock",
    "Script": "it writes the blackboard; in fvtree only skills write it",
    "SetBlackboard": "it writes the blackboard; in fvtree only skills write it",
    "UnsetBlackboard": "it writes the blackboard; in fvtree only skills write it",
    "Precondition": "use a Guard with a _while script, or a ScriptCondition first in a Sequence",
}
INT_PORTS = {(tag, attr) for tag, (_, attr, _) in COUNTED.items()}
PRECONDITIONS = {
    "_skipIf": "py_trees has no SKIPPED status",
    "_failureIf": "put a ScriptCondition before the node in a Sequence",
    "_successIf": "put the node in a Fallback after a ScriptCondition",
    "_onSuccess": "post-condition scripts write the blackboard; only skills write it",
    "_onFailure": "post-condition scripts write the blackboard; only skills write it",
    "_onHalted": "post-condition scripts write the blackboard; only skills write it",
    "_post": "post-condition scripts write the blackboard; only skills write it",
}


@dataclass
class Scope:
    """What a `{key}` port can stand for in the tree being read: a param of the subtree (`$key`),
    or the default the file's `<TreeNodesModel>` declares for a port of the main tree."""

    params: set[str] = field(default_factory=set)
    defaults: dict[str, str] = field(default_factory=dict)
    subtree: bool = False  # a subtree's body (else the main tree)


@dataclass
class _Reader:
    file: str
    out_dir: Path
    subtree_types: dict[str, dict[str, str]]  # subtree -> param -> declared type
    subtree_defaults: dict[str, dict[str, str]] = field(default_factory=dict)  # subtree -> param -> default port
    errors: list[TreeError] = field(default_factory=list)
    keys: set[str] = field(default_factory=known_blackboard_keys)
    scope: Scope = field(default_factory=Scope)
    lines: dict[int, int] = field(default_factory=dict)  # id of a node mapping made -> its XML line
    seen: set[int] = field(default_factory=set)  # ids of the XML nodes read

    def refuse(self, x: XmlNode, message: str, hint: str | None = None) -> None:
        self.errors.append(TreeError(message, self.file, x.line, f"<{x.tag}>", hint))

    def port(self, x: XmlNode, attr: str, type_: str) -> Any:
        try:
            value = from_port(x.attrs[attr], type_)
        except PortError as exc:
            self.refuse(x, f"{attr}: {exc}")
            return None
        ref = PORT_REF.match(x.attrs[attr])
        return self.reference(x, attr, ref.group(1), lambda text: from_port(text, type_)) if ref else value

    def reference(self, x: XmlNode, attr: str, name: str, read: Callable[[str], Any]) -> Any:
        """What a `{name}` port (or a script's bare `name`) is here: the subtree's param `$name`,
        the main tree's declared default for port `name` (read by `read`), or refused (None)."""
        if name in self.scope.params:
            return "$" + name
        if name in self.scope.defaults:
            try:
                return read(self.scope.defaults[name])
            except PortError as exc:
                self.refuse(x, f"{attr}: the default of the tree's port {name!r}: {exc}")
                return None
        try:
            key = key_of_identifier(name, self.keys)
            hint = (f"{key} is read by the skills that need it, not passed as a param; in fvtree only conditions "
                    f"read keys (ScriptCondition code=\"@{name} == ...\")")
        except PortError:
            hint = (f"write the value here, declare a port {name!r} with a default for this tree "
                    f"(Groot2: the tree's port list), or make this part a subtree with a param {name!r}")
        where = "a param of this subtree" if self.scope.subtree else "a port of the main tree with a default"
        self.refuse(x, f"{attr}: {{{name}}} is not {where}: fvtree params are fixed when the tree loads", hint)
        return None

    def children(self, x: XmlNode, one: bool) -> list[dict]:
        if one and len(x.children) != 1:
            self.refuse(x, f"<{x.tag}> takes exactly one child node, got {len(x.children)}")
        elif not one and not x.children:
            self.refuse(x, f"<{x.tag}> has no children")
        out, names = [], set()
        for child in x.children:
            node = self.node(child)
            if node is None:
                continue
            name = _name_of(node)
            if name in names:  # BT.CPP names need not be unique, fvtree paths must be: number them
                base, n = name, 2
                while f"{base}_{n}" in names:
                    n += 1
                name = f"{base}_{n}"
                _rename(node, name)
            names.add(name)
            out.append(node)
        return out

    def node(self, x: XmlNode) -> dict | None:
        self.seen.add(id(x))
        for attr in x.attrs:
            if attr in PRECONDITIONS:
                self.refuse(x, f"attribute {attr} has no equivalent", PRECONDITIONS[attr])
        before = len(self.errors)
        body = self._node(x)
        for child in x.children:  # a refused node's children are read all the same, for their own refusals
            if id(child) not in self.seen:
                self.node(child)
        if body is None or len(self.errors) > before:
            return None
        self.lines[id(body)] = x.line
        if "_description" in x.attrs:
            body["doc"] = x.attrs["_description"]
        if "_while" in x.attrs and x.tag != "Guard":  # a scripted pre-condition: a guard around the node
            cond = self.condition(x, x.attrs["_while"])
            if cond is None:
                return None
            guard = {"guard": f"{_name_of(body)}_while", "while": cond, "child": body}
            self.lines[id(guard)] = x.line
            return guard
        return body

    def own_attrs(self, x: XmlNode, allowed: set[str]) -> None:
        for attr in x.attrs:
            if attr not in allowed and attr not in LAYOUT_ATTRS and attr not in PRECONDITIONS and attr != "name":
                self.refuse(x, f"unknown attribute {attr!r} of <{x.tag}>", did_you_mean(attr, allowed))

    def condition(self, x: XmlNode, code: str) -> dict | None:
        try:
            cond = read_condition_script(code, self.keys)
        except PortError as exc:
            self.refuse(x, f"script: {exc}")
            return None
        value = cond["value"]
        if isinstance(value, str) and value.startswith("$"):  # a bare name: a port of the tree
            cond["value"] = self.reference(x, "script", value[1:], _literal_default)
            if cond["value"] is None:
                return None
        return cond

    def _node(self, x: XmlNode) -> dict | None:
        """The fvtree node of one BT.CPP node (its pre-conditions aside), or None if it is refused."""
        if x.tag in CONVERTERS:
            return CONVERTERS[x.tag](self, x)
        if x.tag in SKILLS:
            return self._skill(x)
        if x.tag in NO_EQUIVALENT:
            self.refuse(x, f"<{x.tag}> has no equivalent", NO_EQUIVALENT[x.tag])
        else:
            self.refuse(x, f"<{x.tag}> is neither a BT.CPP node with an fvtree equivalent nor a skill",
                        did_you_mean(x.tag, [*SKILLS, *COMPOSITES]) or "run 'fvtree skills' to list the skills")
        return None

    def _composite(self, x: XmlNode) -> dict | None:
        """A (reactive) Sequence or Fallback: a sequence or selector, with memory unless reactive."""
        self.own_attrs(x, {"_while"})
        if _is_guard(x):
            return self._marked_guard(x)
        kind, memory = COMPOSITES[x.tag]
        return {kind: _name(x), "memory": memory, "children": self.children(x, one=False)}

    def _marked_guard(self, x: XmlNode) -> dict | None:
        """The exporter's guard: a ReactiveSequence of its condition (named `NAME.while`) and its child."""
        check, child = (self.node(c) for c in x.children)
        if check is None or child is None:
            return None
        return {"guard": _name(x), "while": {k: v for k, v in check.items() if k != "condition"}, "child": child}

    def _parallel(self, x: XmlNode) -> dict | None:
        """BT.CPP's Parallel, for the success and failure counts an fvtree policy has."""
        self.own_attrs(x, {"success_count", "failure_count", "_while"})
        counts = (x.attrs.get("success_count", "-1"), x.attrs.get("failure_count", "1"))
        if counts not in PARALLELS:
            self.refuse(x, f"Parallel success_count={counts[0]} failure_count={counts[1]} has no equivalent",
                        "fvtree parallels fail on the first failure and succeed on all (-1) or one (1)")
            return None
        policy, sync = PARALLELS[counts]
        return {"parallel": _name(x), "policy": policy, "synchronise": sync, "children": self.children(x, one=False)}

    def _fv_parallel(self, x: XmlNode) -> dict:
        """The exporter's FvParallel: an fvtree parallel with its policy as written."""
        self.own_attrs(x, {"policy", "synchronise", "selected", "_while"})
        a = x.attrs
        out = {"parallel": _name(x), "policy": a.get("policy"), "synchronise": self.port(x, "synchronise", "bool")
               if "synchronise" in a else False}
        if a.get("selected", NOT_GIVEN) != NOT_GIVEN:
            out["selected"] = a["selected"].split(";")
        return {**out, "children": self.children(x, one=False)}

    def _counted(self, x: XmlNode) -> dict | None:
        """RetryUntilSuccessful or Repeat: retry or repeat, with its count."""
        kind, attr, ours = COUNTED[x.tag]
        self.own_attrs(x, {attr, "_while"})
        if attr not in x.attrs:
            self.refuse(x, f"<{x.tag}> needs {attr}")
            return None
        return {kind: _name(x), ours: self.port(x, attr, "int"), "child": self._child(x)}

    def _timeout(self, x: XmlNode) -> dict | None:
        """Timeout: a timeout in seconds (a whole number where it is one)."""
        self.own_attrs(x, {"msec", "_while"})
        msec = self.port(x, "msec", "int") if "msec" in x.attrs else None
        if not isinstance(msec, int):
            self.refuse(x, "<Timeout> needs msec as an integer", "fvtree timeouts cannot take a $param")
            return None
        seconds = msec / 1000
        return {"timeout": _name(x), "seconds": int(seconds) if seconds == int(seconds) else seconds,
                "child": self._child(x)}

    def _inverter(self, x: XmlNode) -> dict:
        """Inverter: an inverter."""
        self.own_attrs(x, {"_while"})
        return {"inverter": _name(x), "child": self._child(x)}

    def _status_map(self, x: XmlNode) -> dict:
        """ForceSuccess, ForceFailure or the exporter's StatusMap: a status_map."""
        self.own_attrs(x, {"map", "_while"} if x.tag == "StatusMap" else {"_while"})
        pairs = FORCED.get(x.tag, x.attrs.get("map", ""))
        mapping = dict(p.split(":", 1) for p in pairs.split(";") if ":" in p)
        return {"status_map": _name(x), "map": mapping, "child": self._child(x)}

    def _guard(self, x: XmlNode) -> dict | None:
        """The Guard of files exported before guards were ReactiveSequences: a guard, its
        condition the _while script."""
        self.own_attrs(x, {"_while"})
        if "_while" not in x.attrs:
            self.refuse(x, "<Guard> needs a _while script")
            return None
        cond = self.condition(x, x.attrs["_while"])
        return None if cond is None else {"guard": _name(x), "while": cond, "child": self._child(x)}

    def _for_each_element(self, x: XmlNode) -> dict:
        """The exporter's ForEachElement: for_each_element, over the listed elements if any."""
        self.own_attrs(x, {"elements", "_while"})
        out: dict[str, Any] = {"for_each_element": _name(x)}
        if x.attrs.get("elements", NOT_GIVEN) != NOT_GIVEN:
            out["elements"] = [e for e in x.attrs["elements"].split(";") if e]
        return {**out, "child": self._child(x)}

    def _script_condition(self, x: XmlNode) -> dict | None:
        """ScriptCondition: a condition, if its script is one comparison of a blackboard key."""
        self.own_attrs(x, {"code", "_while"})
        cond = self.condition(x, x.attrs.get("code", ""))
        return None if cond is None else {"condition": _name(x), **cond}

    def _blackboard_check(self, x: XmlNode) -> dict:
        """The exporter's BlackboardCheck: a condition, its value JSON."""
        self.own_attrs(x, {"key", "op", "value", "_while"})
        key = x.attrs.get("key", "")
        ref = PORT_REF.match(key) or re.match(r"^\{(/.*)\}$", key)
        if ref:  # a Groot2 user's {key}: the project's key it spells (fv_left__slip) or holds (/fv/left.slip)
            try:
                key = ref.group(1) if ref.group(1).startswith("/") else key_of_identifier(ref.group(1), self.keys)
            except PortError as exc:
                self.refuse(x, f"key: {exc}")
        out = {"condition": _name(x), "key": key, "op": x.attrs.get("op")}
        if x.attrs.get("value", NOT_GIVEN) != NOT_GIVEN:
            try:
                out["value"] = json.loads(x.attrs["value"])
            except json.JSONDecodeError:
                self.refuse(x, f"value: not JSON: {x.attrs['value']!r}")
        return out

    def _child(self, x: XmlNode) -> dict | None:
        kids = self.children(x, one=True)
        return kids[0] if kids else None

    def _skill(self, x: XmlNode) -> dict:
        """A node whose tag is a skill's name: the skill, its ports as params (model files rebased)."""
        cls = SKILLS[x.tag]
        self.own_attrs(x, {*cls.PARAMS, "_while"})
        params = {k: self.port(x, k, cls.PARAMS[k].type) for k, v in x.attrs.items() if k in cls.PARAMS
                  and not (v == NOT_GIVEN and not cls.PARAMS[k].required and cls.PARAMS[k].default is None)}
        if issubclass(cls, UsesModel) and isinstance(params.get("model"), str) and not params["model"].startswith("$"):
            params["model"] = rebase(params["model"], Path(self.file).parent, self.out_dir)
        out: dict[str, Any] = {"skill": x.tag}
        if x.attrs.get("name", x.tag) != x.tag:
            out["name"] = x.attrs["name"]
        if params:
            out["params"] = params
        return out

    def _subtree(self, x: XmlNode) -> dict | None:
        """SubTree: a subtree of this file, its ports as params typed by the subtree's declaration."""
        ref = x.attrs.get("ID")
        if ref not in self.subtree_types:
            self.refuse(x, f"<SubTree ID={ref!r}> names no <BehaviorTree> of this file",
                        did_you_mean(ref, self.subtree_types))
            return None
        types, defaults = self.subtree_types[ref], self.subtree_defaults.get(ref, {})
        implied = set(x.attrs.get(DEFAULTS_ATTR, "").split(";"))  # written only for BT.CPP: left out again
        params = {k: self.port(x, k, types.get(k, "str")) for k in x.attrs
                  if k not in ("ID", "name", "_autoremap", "_while", DEFAULTS_ATTR) and k not in LAYOUT_ATTRS
                  and not (k in implied and k in defaults and x.attrs[k] == defaults[k])}
        params.update(self._autoremapped(x, types, defaults, set(x.attrs)))
        out: dict[str, Any] = {"subtree": ref}
        if x.attrs.get("name", ref) != ref:
            out["name"] = x.attrs["name"]
        if params:
            out["params"] = params
        return out


    def _autoremapped(self, x: XmlNode, types: dict[str, str], defaults: dict[str, str],
                      given: set[str]) -> dict[str, Any]:
        """The params `_autoremap="true"` passes a SubTree: each param it is not given that has a
        namesake here (the enclosing subtree's param, `$name`; the main tree's port default, its
        value), as BT.CPP remaps it to the same key of the parent blackboard. A param without a
        namesake keeps the subtree's default; one without a default either is refused."""
        flag = x.attrs.get("_autoremap", "false")
        if flag not in ("true", "false"):
            self.refuse(x, f"_autoremap: expected true or false, got {flag!r}",
                        "a blackboard entry for _autoremap has no equivalent: fvtree params are fixed when the tree loads")
            return {}
        if flag == "false":
            return {}
        out: dict[str, Any] = {}
        for name, type_ in types.items():
            if name in given:
                continue
            if name in self.scope.params or name in self.scope.defaults:
                out[name] = self.reference(x, "_autoremap", name, partial(from_port, type_=type_))
            elif name not in defaults:
                where = "param of the enclosing subtree" if self.scope.subtree else "port of the main tree"
                self.refuse(x, f"_autoremap: the subtree's param {name!r} has no default, and no {where} is "
                               f"named {name!r} to remap it to", f"pass it as a port: {name}=\"...\"")
        return out


CONVERTERS: dict[str, Callable[[_Reader, XmlNode], dict | None]] = {
    **dict.fromkeys(COMPOSITES, _Reader._composite), "Parallel": _Reader._parallel,
    "FvParallel": _Reader._fv_parallel, **dict.fromkeys(COUNTED, _Reader._counted), "Timeout": _Reader._timeout,
    "Inverter": _Reader._inverter, **dict.fromkeys(("ForceSuccess", "ForceFailure", "StatusMap"), _Reader._status_map),
    "Guard": _Reader._guard, "ForEachElement": _Reader._for_each_element,
    "ScriptCondition": _Reader._script_condition, "BlackboardCheck": _Reader._blackboard_check,
    "SubTree": _Reader._subtree,
}  # BT.CPP tag -> the converter to its fvtree node kind (a tag that is a skill's name: _Reader._skill)


def _name(x: XmlNode) -> str:
    """The node's name: its `name` attribute, else its tag."""
    return x.attrs.get("name", x.tag)


def _is_guard(x: XmlNode) -> bool:
    """Whether `x` is an exported guard: a ReactiveSequence of two nodes, the first a plain condition
    named after it (`NAME.while`). Any such sequence behaves as the guard it is read as."""
    if x.tag != "ReactiveSequence" or len(x.children) != 2:
        return False
    check = x.children[0]
    plain = {"name", "code"} if check.tag == "ScriptCondition" else {"name", "key", "op", "value"}
    return (check.tag in ("ScriptCondition", "BlackboardCheck") and set(check.attrs) - {"_uid", "_fullpath"} <= plain
            and check.attrs.get("name") == guard_condition_name(_name(x)))


def _kind_key(node: dict) -> str:
    return next(iter(node))


def _name_of(node: dict) -> str:
    return node.get("name", node[_kind_key(node)]) if _kind_key(node) in ("skill", "subtree") else node[_kind_key(node)]


def _rename(node: dict, name: str) -> None:
    if _kind_key(node) in ("skill", "subtree"):
        node["name"] = name
    else:
        node[_kind_key(node)] = name


def import_xml(path: str | Path, out: str | Path) -> str:
    """The YAML text of a BT.CPP v4 XML file, to be written at `out` (paths made relative to it),
    validated; TreeErrors listing every XML node without an equivalent, or what validation found."""
    file = str(path)
    root = parse_xml_file(path)
    if root.tag != "root" or root.attrs.get("BTCPP_format") != "4":
        raise TreeErrors([TreeError("not BehaviorTree.CPP v4 XML: expected <root BTCPP_format=\"4\">", file,
                                    root.line, hint="open and save a v3 file in Groot2 to convert it")])
    meta = metadata(root, file)
    trees = {t.attrs.get("ID", ""): t for t in root.children if t.tag == "BehaviorTree"}
    model = next((t for t in root.children if t.tag == "TreeNodesModel"), None)
    errors = [TreeError("<include> is not followed: merge the included trees into this file", file, t.line,
                        "<include>") for t in root.children if t.tag == "include"]
    main = root.attrs.get("main_tree_to_execute") or (next(iter(trees)) if len(trees) == 1 else None)
    if main not in trees:
        errors.append(TreeError(f"no main tree: main_tree_to_execute is {main!r}", file, root.line,
                                hint=f"trees in this file: {', '.join(trees) or 'none'}"))
        raise TreeErrors(errors)
    ours, groot = meta.get("subtrees") or {}, groot_subtree_params(model, trees, file, INT_PORTS)
    main_defaults = default_ports(groot.get(main, {}))
    subtrees = {name: ours[name].get("params", {}) if name in ours else groot.get(name, {})
                for name in trees if name != main}
    out_dir = Path(out).parent
    reader = _Reader(file, out_dir, {n: {p: d.get("type", "str") for p, d in ps.items()} for n, ps in subtrees.items()},
                     {n: default_ports(ps) for n, ps in subtrees.items()})
    reader.errors = errors

    def body(tree: XmlNode, scope: Scope) -> dict | None:
        reader.scope = scope
        if len(tree.children) != 1:
            reader.refuse(tree, f"a <BehaviorTree> holds one root node, got {len(tree.children)}")
            for child in tree.children:
                reader.node(child)
            return None
        return reader.node(tree.children[0])

    doc: dict[str, Any] = {"version": 1, "name": meta.get("name", main)}
    for key in ("doc", "cell"):
        if key in meta:
            doc[key] = meta[key]
    if "design" in meta:
        doc["design"] = rebase(meta["design"], Path(file).parent, out_dir)
    if subtrees:
        doc["subtrees"] = {name: {**({"params": params} if params else {}), "root": body(trees[name], Scope(set(params), subtree=True))}
                           for name, params in subtrees.items()}
    doc["root"] = body(trees[main], Scope(defaults=main_defaults))
    if reader.errors:
        raise TreeErrors(sorted(reader.errors, key=lambda e: e.line or 0))
    text = yaml.safe_dump(_plain(doc), sort_keys=False, default_flow_style=None, width=110)
    try:
        load_tree(text=text, name=str(out))  # the result validates, or says why not
    except TreeErrors as exc:  # said of the YAML we made: said again of the XML lines it came from
        raise relocate(exc, str(out), file, node_lines(doc, reader.lines)) from None
    return text


def _literal_default(text: str) -> Any:
    """A declared port default used as a script's value: a number or true/false, else the string."""
    try:
        value = literal(text)
    except PortError:
        return text
    return text if isinstance(value, str) and value.startswith("$") else value


def _plain(value: Any) -> Any:
    """Plain dicts and lists (YAML dumps Located mappings from the metadata as plain ones)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value
