"""The YAML tree language: node kinds, their fields, and validation into `NodeSpec`s.

A node is a mapping whose kind is given by one key (DESIGN.md): `sequence: NAME`,
`selector: NAME`, `parallel: NAME`, `retry: NAME`, `repeat: NAME`, `timeout: NAME`,
`inverter: NAME`, `status_map: NAME`, `guard: NAME`, `for_each_element: NAME`,
`condition: NAME`, `skill: TYPE` and `subtree: REF` (the last two take `name:`, defaulting
to the type). Validation walks the whole file, expands subtrees (substituting `$param`
values) and collects every problem with its file, line and node path.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from assembly.conditions import ALL_OPS, split_key
from assembly.errors import TreeError, did_you_mean
from assembly.yaml_source import Located
from behaviours import keys as bbkeys
from behaviours.base import REQUIRED, Param
from behaviours.registry import SKILLS

KINDS: dict[str, dict[str, set[str]]] = {
    "sequence": {"required": {"memory", "children"}, "optional": set()},
    "selector": {"required": {"memory", "children"}, "optional": set()},
    "parallel": {"required": {"policy", "children"}, "optional": {"synchronise", "selected"}},
    "retry": {"required": {"attempts", "child"}, "optional": set()},
    "repeat": {"required": {"times", "child"}, "optional": set()},
    "timeout": {"required": {"seconds", "child"}, "optional": set()},
    "inverter": {"required": {"child"}, "optional": set()},
    "status_map": {"required": {"map", "child"}, "optional": set()},
    "guard": {"required": {"while", "child"}, "optional": set()},
    "for_each_element": {"required": {"child"}, "optional": {"elements"}},
    "condition": {"required": {"key", "op"}, "optional": {"value"}},
    "skill": {"required": set(), "optional": {"name", "params"}},
    "subtree": {"required": set(), "optional": {"name", "params"}},
}
COMMON_FIELDS = {"doc"}
STATUSES = ("success", "failure", "running")
POLICIES = ("all", "one", "selected")
PARAM_TYPES = ("float", "int", "bool", "str", "vector")


@dataclass
class NodeSpec:
    """A validated node, ready to be built into a py_trees behaviour."""

    kind: str
    name: str
    path: str
    args: dict[str, Any]
    children: list["NodeSpec"] = field(default_factory=list)
    file: str = ""
    line: int = 0
    type: str = ""  # the skill type or subtree ref


@dataclass
class SubtreeDef:
    name: str
    params: dict[str, Param]
    root: Located
    file: str
    line: int


def known_blackboard_keys() -> set[str]:
    found = set(bbkeys.PERCEPTION_KEYS) | set(bbkeys.TASK_KEYS)
    for cls in SKILLS.values():
        found |= set(cls.WRITES)
    return found


class Validator:
    """Turns the root mapping of a tree document into a NodeSpec tree, collecting errors."""

    def __init__(self, subtrees: dict[str, SubtreeDef], has_design: bool):
        self.subtrees = subtrees
        self.has_design = has_design
        self.errors: list[TreeError] = []
        self._keys = known_blackboard_keys()

    # ---- helpers ------------------------------------------------------------------------
    def error(self, node, message: str, path: str, key: str | None = None, hint: str | None = None):
        file = getattr(node, "file", None)
        line = node.line_of(key) if isinstance(node, Located) and key else getattr(node, "line", None)
        self.errors.append(TreeError(message, file, line, path, hint))

    def _kind(self, node: Located, path: str) -> str | None:
        kinds = [k for k in node if k in KINDS]
        if len(kinds) == 1:
            return kinds[0]
        if not kinds:
            unknown = next((k for k in node if k not in COMMON_FIELDS and k != "name"), None)
            self.error(node, f"unknown node kind {unknown!r}" if unknown else "node has no kind",
                       path, unknown, did_you_mean(unknown, KINDS) if unknown else
                       f"start the node with one of: {', '.join(KINDS)}")
        else:
            self.error(node, f"node has several kinds: {', '.join(kinds)}", path, kinds[1])
        return None

    # ---- nodes --------------------------------------------------------------------------
    def node(self, node: Any, parent: str, subs: dict[str, Any], stack: tuple[str, ...]) -> NodeSpec | None:
        if not isinstance(node, Located):
            self.errors.append(TreeError(f"a node must be a mapping, got {node!r}", None, None, parent or "/"))
            return None
        kind = self._kind(node, parent or "/")
        if kind is None:
            return None
        value = node[kind]
        if kind in ("skill", "subtree"):
            type_, name = value, node.get("name", value)
        else:
            type_, name = "", value
        if not isinstance(name, str) or not name or "/" in name:
            self.error(node, f"node name must be a non-empty string without '/', got {name!r}",
                       parent or "/", kind)
            return None
        path = f"{parent}/{name}" if parent else name
        spec_fields = KINDS[kind]
        allowed = spec_fields["required"] | spec_fields["optional"] | COMMON_FIELDS | {kind}
        for key in node:
            if key not in allowed:
                self.error(node, f"unknown field {key!r} for a {kind}", path, key,
                           did_you_mean(key, allowed - {kind}))
        for key in sorted(spec_fields["required"] - set(node)):
            self.error(node, f"missing required field {key!r} for a {kind}", path, kind)
        if spec_fields["required"] - set(node):
            return None
        spec = NodeSpec(kind, name, path, {}, [], node.file, node.line, type_)
        handler = getattr(self, f"_{kind}")
        return handler(spec, self._with_params(node, kind, subs, spec), subs, stack)

    _SUBSTITUTED_ELSEWHERE = {"children", "child", "params", "while", "key", "value"}

    def _with_params(self, node: Located, kind: str, subs: dict, spec: NodeSpec) -> Located:
        """The node with `$param` values of its own fields (e.g. `times: $count`) filled in."""
        fields = [k for k in node if k != kind and k not in self._SUBSTITUTED_ELSEWHERE]
        if not any(isinstance(node[k], (str, list)) for k in fields):
            return node
        out = Located(node)
        out.file, out.line, out.key_lines = node.file, node.line, node.key_lines
        for key in fields:
            out[key] = self._substitute(node[key], subs, spec, node)
        return out

    def _children(self, spec, node, subs, stack, key="children"):
        items = node[key]
        if key == "child":
            items = [items]
        elif not isinstance(items, list) or not items:
            self.error(node, f"'{key}' must be a non-empty list of nodes", spec.path, key)
            return spec
        names = {}
        for item in items:
            child = self.node(item, spec.path, subs, stack)
            if child is None:
                continue
            if child.name in names:
                self.error(item, f"duplicate name {child.name!r} among the children of {spec.path}",
                           child.path, hint=f"first used on line {names[child.name]}")
            names[child.name] = child.line
            spec.children.append(child)
        return spec

    def _bool(self, spec, node, key):
        if not isinstance(node[key], bool):
            self.error(node, f"'{key}' must be true or false, got {node[key]!r}", spec.path, key)
        return node[key]

    def _sequence(self, spec, node, subs, stack):
        spec.args["memory"] = self._bool(spec, node, "memory")
        return self._children(spec, node, subs, stack)

    _selector = _sequence

    def _parallel(self, spec, node, subs, stack):
        policy = node["policy"]
        if policy not in POLICIES:
            self.error(node, f"policy must be one of {', '.join(POLICIES)}, got {policy!r}",
                       spec.path, "policy", did_you_mean(policy, POLICIES))
        spec.args["policy"] = policy
        spec.args["synchronise"] = node.get("synchronise", False)
        if "synchronise" in node:
            self._bool(spec, node, "synchronise")
        self._children(spec, node, subs, stack)
        selected = node.get("selected")
        if policy == "selected":
            names = [c.name for c in spec.children]
            if not isinstance(selected, list) or not selected:
                self.error(node, "policy 'selected' needs 'selected: [child names]'", spec.path, "policy")
            else:
                for s in selected:
                    if s not in names:
                        self.error(node, f"selected child {s!r} is not a child of this parallel",
                                   spec.path, "selected", did_you_mean(s, names))
            spec.args["selected"] = selected or []
        elif selected is not None:
            self.error(node, "'selected' only applies to policy 'selected'", spec.path, "selected")
        return spec

    def _count(self, spec, node, key, minimum, allow_forever=False):
        value = node[key]
        ok = isinstance(value, int) and not isinstance(value, bool) and (
            value >= minimum or (allow_forever and value == -1))
        if not ok:
            extra = " (or -1 for ever)" if allow_forever else ""
            self.error(node, f"'{key}' must be an integer >= {minimum}{extra}, got {value!r}", spec.path, key)
        spec.args[key] = value

    def _retry(self, spec, node, subs, stack):
        self._count(spec, node, "attempts", 1)
        return self._children(spec, node, subs, stack, "child")

    def _repeat(self, spec, node, subs, stack):
        self._count(spec, node, "times", 1, allow_forever=True)
        return self._children(spec, node, subs, stack, "child")

    def _timeout(self, spec, node, subs, stack):
        seconds = node["seconds"]
        if not isinstance(seconds, (int, float)) or isinstance(seconds, bool) or seconds <= 0:
            self.error(node, f"'seconds' must be a positive number, got {seconds!r}", spec.path, "seconds")
        spec.args["seconds"] = seconds
        return self._children(spec, node, subs, stack, "child")

    def _inverter(self, spec, node, subs, stack):
        return self._children(spec, node, subs, stack, "child")

    def _status_map(self, spec, node, subs, stack):
        mapping = node["map"]
        if not isinstance(mapping, dict) or not mapping:
            self.error(node, "'map' must map statuses, e.g. {failure: success}", spec.path, "map")
        else:
            for k, v in mapping.items():
                for s in (k, v):
                    if s not in STATUSES:
                        self.error(node, f"unknown status {s!r} in 'map'", spec.path, "map",
                                   did_you_mean(s, STATUSES) or f"use {', '.join(STATUSES)}")
        spec.args["map"] = dict(mapping) if isinstance(mapping, dict) else {}
        return self._children(spec, node, subs, stack, "child")

    def _guard(self, spec, node, subs, stack):
        cond = node["while"]
        if not isinstance(cond, Located):
            self.error(node, "'while' must be a condition mapping {key, op, value}", spec.path, "while")
        else:
            spec.args["while"] = self._check_condition(spec, cond, subs)
        return self._children(spec, node, subs, stack, "child")

    def _for_each_element(self, spec, node, subs, stack):
        if not self.has_design:
            self.error(node, "for_each_element needs a design model", spec.path, "for_each_element",
                       "add 'design: path/to/model.json' at the top of the tree file")
        spec.args["elements"] = node.get("elements")
        return self._children(spec, node, subs, stack, "child")

    def _condition(self, spec, node, subs, stack):
        spec.args.update(self._check_condition(spec, node, subs))
        return spec

    def _check_condition(self, spec, node, subs) -> dict:
        key, op = self._substitute(node.get("key"), subs, spec, node), node.get("op")
        value = self._substitute(node.get("value"), subs, spec, node)
        try:
            base, _ = split_key(str(key))
            if base not in self._keys:
                self.error(node, f"unknown blackboard key {base!r}", spec.path, "key",
                           did_you_mean(base, self._keys))
        except ValueError as exc:
            self.error(node, str(exc), spec.path, "key")
        if op not in ALL_OPS:
            self.error(node, f"unknown op {op!r}; use one of {', '.join(ALL_OPS)}", spec.path, "op",
                       did_you_mean(op, ALL_OPS))
        elif op != "exists" and "value" not in node:
            self.error(node, f"op {op!r} needs a 'value'", spec.path, "op")
        return {"key": key, "op": op, "value": value}

    def _skill(self, spec, node, subs, stack):
        cls = SKILLS.get(spec.type)
        if cls is None:
            self.error(node, f"unknown skill {spec.type!r}", spec.path, "skill",
                       did_you_mean(spec.type, SKILLS) or "run 'fvtree skills' to list them")
            return spec
        params = self._params(spec, node, subs)
        unknown = [key for key in params if key not in cls.PARAMS]
        for key in unknown:
            self.error(node, f"unknown param {key!r} for skill {spec.type!r}", spec.path, "params",
                       did_you_mean(key, cls.PARAMS) or f"known: {', '.join(cls.PARAMS) or 'none'}")
        if unknown:
            return spec
        try:
            spec.args["params"] = cls.resolve_params(params)
        except (KeyError, ValueError) as exc:
            self.error(node, str(exc).strip("'\""), spec.path, "params")
        return spec

    def _params(self, spec, node, subs) -> dict:
        params = node.get("params", {}) or {}
        if not isinstance(params, dict):
            self.error(node, f"'params' must be a mapping, got {params!r}", spec.path, "params")
            return {}
        return {k: self._substitute(v, subs, spec, node) for k, v in params.items()}

    def _substitute(self, value, subs, spec, node):
        if isinstance(value, str) and value.startswith("$"):
            if value[1:] in subs:
                return subs[value[1:]]
            self.error(node, f"{value} is not a parameter of the enclosing subtree", spec.path,
                       hint=did_you_mean(value[1:], subs) or (
                           f"its params: {', '.join(subs)}" if subs else "only subtrees take $params"))
            return None
        if isinstance(value, list):
            return [self._substitute(v, subs, spec, node) for v in value]
        return value

    def _subtree(self, spec, node, subs, stack):
        ref = spec.type
        definition = self.subtrees.get(ref)
        if definition is None:
            self.error(node, f"unknown subtree {ref!r}", spec.path, "subtree",
                       did_you_mean(ref, self.subtrees) or "define it under 'subtrees:' or include its file")
            return spec
        if ref in stack:
            chain = " -> ".join(stack[stack.index(ref):] + (ref,))
            self.error(node, f"recursive subtree: {chain}", spec.path, "subtree")
            return spec
        given = self._params(spec, node, subs)
        values = {}
        before = len(self.errors)
        for key in given:
            if key not in definition.params:
                self.error(node, f"unknown param {key!r} for subtree {ref!r}", spec.path, "params",
                           did_you_mean(key, definition.params) or
                           f"known: {', '.join(definition.params) or 'none'}")
        for key, decl in definition.params.items():
            if key in given:
                try:
                    values[key] = decl.check(given[key])
                except ValueError as exc:
                    self.error(node, f"param {key!r}: {exc}", spec.path, "params")
            elif decl.required:
                self.error(node, f"missing param {key!r} for subtree {ref!r}", spec.path, "subtree")
            else:
                values[key] = decl.default
        if len(self.errors) > before:
            return spec  # the body would only repeat the parameter problems
        body = self.node(definition.root, spec.path, values, stack + (ref,))
        if body is not None:
            spec.children.append(body)
        return spec


def subtree_params(raw: Any, where: Located, name: str, errors: list[TreeError]) -> dict[str, Param]:
    """Declared subtree params: `{p: float}` or `{p: {type: float, default: 1.0, doc: ...}}`."""
    out: dict[str, Param] = {}
    if raw is None:
        return out
    if not isinstance(raw, dict):
        errors.append(TreeError("subtree 'params' must be a mapping", where.file, where.line_of("params"),
                                f"subtrees/{name}"))
        return out
    for pname, decl in raw.items():
        if isinstance(decl, str):
            decl = {"type": decl}
        ptype = decl.get("type") if isinstance(decl, dict) else None
        if ptype not in PARAM_TYPES:
            errors.append(TreeError(f"param {pname!r}: type must be one of {', '.join(PARAM_TYPES)}",
                                    where.file, where.line_of("params"), f"subtrees/{name}",
                                    did_you_mean(ptype, PARAM_TYPES)))
            continue
        extra = set(decl) - {"type", "default", "doc", "unit"}
        if extra:
            errors.append(TreeError(f"param {pname!r}: unknown field {sorted(extra)[0]!r}", where.file,
                                    where.line_of("params"), f"subtrees/{name}"))
        out[pname] = Param(ptype, decl.get("doc", ""), decl.get("default", REQUIRED), decl.get("unit", ""))
    return out

