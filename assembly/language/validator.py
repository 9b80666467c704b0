"""The YAML tree language: what a node kind is, and validation of a tree into `NodeSpec`s.

A node is a mapping whose kind is given by one key (`sequence: NAME`, `skill: TYPE`, ...; the
kinds are the table in `assembly.language.kinds`). Validation walks the whole file, expands subtrees
(substituting `$param` values) and collects every problem with its file, line and node path.
"""

from __future__ import annotations

import math
import reprlib
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from py_trees.behaviour import Behaviour

from assembly.errors import TreeError
from assembly.language.blackboard import key_problem
from assembly.nodes.conditions import ALL_OPS, split_key
from behaviours.skill_kit import keys as bbkeys
from behaviours.skill_kit.base import DEVICE_RANGES, REQUIRED, Param
from behaviours.skill_kit.registry import SKILLS
from drivers.device_ranges import DeviceRange
from fvfiles.errors import did_you_mean
from fvfiles.yaml_source import Located, LocatedList

# Units a subtree param may be declared in where a param takes another: the factor to the other's
# (for the hint of a mismatch; values are never converted).
UNIT_FACTORS = {("ms", "s"): 1e-3, ("s", "ms"): 1e3, ("mm", "m"): 1e-3, ("m", "mm"): 1e3, ("cm", "m"): 1e-2,
                ("mm/s", "m/s"): 1e-3, ("m/s", "mm/s"): 1e3, ("deg", "rad"): math.pi / 180,
                ("rad", "deg"): 180 / math.pi, ("deg/s", "rad/s"): math.pi / 180, ("kN", "N"): 1e3}
MAX_NODES = 10_000  # nodes of a tree once its subtrees are expanded (subtrees can multiply them)
MAX_DEPTH = 200  # levels of nodes
PARAM_TYPES = ("float", "int", "bool", "str", "vector")
PARAM_FIELDS = ("type", "default", "doc", "unit")  # of a subtree param declaration
NODE_FIELDS = ("child", "children")  # fields holding nodes, validated when the walk reaches them
COMMON_FIELDS = {"doc": {"type": "string"}}  # fields every node may have -> JSON Schema of the value


@dataclass
class NodeSpec:
    """A validated node, ready to be built into a py_trees behaviour."""

    kind: str
    name: str
    path: str
    args: dict[str, Any]
    children: list[NodeSpec] = field(default_factory=list)
    file: str = ""
    line: int = 0
    type: str = ""  # the skill type or subtree ref

    def skills(self) -> Iterator[NodeSpec]:
        """The skill nodes under this one, itself first, in tick order."""
        if self.kind == "skill":
            yield self
        for child in self.children:
            yield from child.skills()


@dataclass
class SubtreeDef:
    """A subtree as declared: its typed params and its (not yet validated) root node."""

    name: str
    params: dict[str, Param]
    root: Located
    file: str
    line: int


@dataclass(frozen=True)
class CellRanges:
    """The cell a tree is validated for: its name and its devices' ranges (`drivers.device_ranges`)."""

    name: str
    ranges: Mapping[str, DeviceRange]


@dataclass(frozen=True)
class Scope:
    """Where a node sits: the `$param` values of the enclosing subtree and the chain of subtrees."""

    params: dict[str, Any] = field(default_factory=dict)
    subtrees: tuple[str, ...] = ()

    def enter(self, subtree: str, params: dict[str, Any]) -> Scope:
        return Scope(params, self.subtrees + (subtree,))


@dataclass(frozen=True)
class NodeKind:
    """One node kind: `<kind>: VALUE` plus its fields.

    `check(validator, spec, node, scope)` reads the node's fields into `spec.args` (reporting
    problems through the validator) and validates its children; `build(spec, children)` returns
    the py_trees behaviour. `value` is what the kind's own key holds: the node's NAME, or a TYPE/REF
    whose node name then comes from an optional `name:` field (defaulting to it).
    """

    doc: str
    fields: Mapping[str, dict]  # field -> JSON Schema of its value
    required: frozenset[str]
    check: Callable[[Validator, NodeSpec, Located, Scope], None]
    build: Callable[[NodeSpec, list[Behaviour]], Behaviour]
    label: Callable[[NodeSpec], str] = lambda spec: f"[{spec.kind}]"
    value: str = "NAME"
    substitutes: frozenset[str] = frozenset()  # fields whose `$param`s `check` fills in itself
    variants: Callable[[str, NodeKind], list[dict]] | None = None  # when fields cannot say the schema
    # Dataflow (`dataflow_errors`): blackboard keys the node (reads, writes) itself, the keys it
    # publishes to its children, and whether its children tick together (each sees every sibling).
    keys: Callable[[NodeSpec], tuple[Iterable[str], Iterable[str]]] | None = None
    publishes: frozenset[str] = frozenset()
    concurrent: bool = False

    def __post_init__(self):
        if not self.required <= set(self.fields):
            raise ValueError(f"required fields {sorted(self.required - set(self.fields))} are not fields")

    @property
    def typed(self) -> bool:
        """Whether the kind's key holds a type (`skill: TYPE`) rather than the node's name."""
        return self.value != "NAME"

    def json_schema(self, name: str) -> list[dict]:
        """The JSON Schema variants of a node of this kind (one, unless `variants` says more)."""
        if self.variants is not None:
            return self.variants(name, self)
        properties = {name: {"type": "string"}, **self.fields, **COMMON_FIELDS}
        return [{"type": "object", "required": [name, *sorted(self.required)], "additionalProperties": False,
                 "properties": properties, "description": self.doc}]


def short(value: Any) -> str:
    """`repr` of a value from a file, cut short enough for an error message."""
    return _SHORT.repr(value)


_SHORT = reprlib.Repr()
_SHORT.maxstring = _SHORT.maxother = 80


def known_blackboard_keys() -> set[str]:
    """Every key a condition may read: perception, task keys and what some skill writes."""
    found = set(bbkeys.PERCEPTION_KEYS) | set(bbkeys.TASK_KEYS)
    for cls in SKILLS.values():
        found |= set(cls.WRITES)
    return found


class Validator:
    """Turns the root node of a tree document into a NodeSpec tree, collecting errors.

    The walk is generic: `kinds` (the table `assembly.language.kinds.NODE_KINDS`) says which fields
    each kind has, and each kind's `check` reads its own fields with the helpers below.
    """

    def __init__(self, kinds: Mapping[str, NodeKind], subtrees: dict[str, SubtreeDef], has_design: bool,
                 element_ids: Iterable[str] | None = None, cell: CellRanges | None = None):
        self.kinds = kinds
        self.cell = cell  # the device ranges skill params are checked against (None: not checked)
        self.subtrees = subtrees
        self.has_design = has_design
        self.element_ids = None if element_ids is None else frozenset(element_ids)  # None: not known
        self.errors: list[TreeError] = []
        self.nodes = 0
        self.too_large = False
        self._keys = known_blackboard_keys()

    def error(self, node: Any, message: str, path: str, key: str | None = None, hint: str | None = None) -> None:
        """Record a problem at `node` (at the line of its field `key`, if given)."""
        file = getattr(node, "file", None)
        line = node.line_of(key) if isinstance(node, Located) and key else getattr(node, "line", None)
        self.errors.append(TreeError(message, file, line, path, hint))

    # ---- the walk ------------------------------------------------------------------------------
    def node(self, node: Any, parent: str, scope: Scope, where: tuple[str | None, int | None] = (None, None)
             ) -> NodeSpec | None:
        """The NodeSpec of one node and its subtree of nodes; None when it cannot even be named.
        `where` (file, line) locates a node that is not a mapping (and so has no line of its own)."""
        if not isinstance(node, Located):
            self.errors.append(TreeError(f"a node must be a mapping, got {short(node)}", *where, parent or "/"))
            return None
        self.nodes += 1
        if self.nodes > MAX_NODES or parent.count("/") >= MAX_DEPTH:
            if not self.too_large:  # say it once
                self.too_large = True
                self.error(node, f"the tree has more than {MAX_NODES} nodes or is nested deeper than "
                           f"{MAX_DEPTH} once its subtrees are expanded", parent)
            return None
        name_of_kind = self._kind(node, parent or "/")
        if name_of_kind is None:
            return None
        kind = self.kinds[name_of_kind]
        value = node[name_of_kind]
        if kind.typed and not isinstance(value, str):
            self.error(node, f"'{name_of_kind}' takes a {kind.value.lower()} name, got {short(value)}",
                       parent or "/", name_of_kind)
            return None
        type_, name = (value, node.get("name", value)) if kind.typed else ("", value)
        if not isinstance(name, str) or not name or "/" in name:
            self.error(node, f"node name must be a non-empty string without '/', got {short(name)}",
                       parent or "/", name_of_kind)
            return None
        if not (name.isascii() and name.isprintable()):
            escaped = name.encode("ascii", "backslashreplace").decode()
            self.error(node, f"node name '{escaped}' holds a character that is not printable ASCII",
                       parent or "/", "name" if "name" in node else name_of_kind,
                       "node names are printable ASCII, so that two names that print alike are one name "
                       "(a Cyrillic a, a zero-width space)")
            return None
        path = f"{parent}/{name}" if parent else name
        allowed = {*kind.fields, *COMMON_FIELDS}
        for key in node:
            if key not in allowed and key != name_of_kind:
                self.error(node, f"unknown field {key!r} for a {name_of_kind}", path, key,
                           did_you_mean(key, allowed))
        missing = sorted(kind.required - set(node))
        for key in missing:
            self.error(node, f"missing required field {key!r} for a {name_of_kind}", path, name_of_kind)
        if missing:
            return None
        spec = NodeSpec(name_of_kind, name, path, {}, [], node.file, node.line, type_)
        own = [k for k in node if k != name_of_kind and k not in NODE_FIELDS and k not in kind.substitutes]
        kind.check(self, spec, self._with_params(node, own, scope, spec), scope)
        return spec

    def _kind(self, node: Located, path: str) -> str | None:
        kinds = [k for k in node if k in self.kinds]
        if len(kinds) == 1:
            return kinds[0]
        if not kinds:
            unknown = next((k for k in node if k not in COMMON_FIELDS and k != "name"), None)
            self.error(node, f"unknown node kind {unknown!r}" if unknown else "node has no kind",
                       path, unknown, did_you_mean(unknown, self.kinds) if unknown else
                       f"start the node with one of: {', '.join(self.kinds)}")
        else:
            self.error(node, f"node has several kinds: {', '.join(kinds)}", path, kinds[1])
        return None

    def _with_params(self, node: Located, fields: list[str], scope: Scope, spec: NodeSpec) -> Located:
        """The node with `$param` values of the given fields (e.g. `times: $count`) filled in."""
        if not any(isinstance(node[k], (str, list)) for k in fields):
            return node
        out = Located(node)
        out.file, out.line, out.key_lines = node.file, node.line, node.key_lines
        for key in fields:
            out[key] = self.substitute(node[key], scope, spec, node)
        return out

    # ---- helpers for the kinds' checks -----------------------------------------------------------
    def children(self, spec: NodeSpec, node: Located, scope: Scope, key: str = "children") -> None:
        """Validate the node(s) under `key` (`child` or `children`) into spec.children."""
        items = node[key]
        if key == "child":
            items = [items]
        elif not isinstance(items, list) or not items:
            self.error(node, f"'{key}' must be a non-empty list of nodes", spec.path, key)
            return
        lines = items.item_lines if isinstance(items, LocatedList) else [node.line_of(key)] * len(items)
        names: dict[str, int] = {}  # child name -> its line
        for item, line in zip(items, lines):
            child = self.node(item, spec.path, scope, (node.file, line))
            if child is None:
                continue
            if child.name in names:
                self.error(item, f"duplicate name {child.name!r} among the children of {spec.path}",
                           child.path, hint=f"first used on line {names[child.name]}")
            names[child.name] = child.line
            spec.children.append(child)

    def flag(self, spec: NodeSpec, node: Located, key: str) -> Any:
        """The field `key`, which must be true or false."""
        if not isinstance(node[key], bool):
            self.error(node, f"'{key}' must be true or false, got {short(node[key])}", spec.path, key)
        return node[key]

    def count(self, spec: NodeSpec, node: Located, key: str, minimum: int, allow_forever: bool = False) -> Any:
        """The field `key`, which must be an integer >= minimum (or -1 when `allow_forever`)."""
        value = node[key]
        ok = isinstance(value, int) and not isinstance(value, bool) and (
            value >= minimum or (allow_forever and value == -1))
        if not ok:
            extra = " (or -1 for ever)" if allow_forever else ""
            self.error(node, f"'{key}' must be an integer >= {minimum}{extra}, got {short(value)}", spec.path, key)
        return value

    def condition(self, spec: NodeSpec, node: Located, scope: Scope) -> dict:
        """`{key, op, value}` of a condition mapping, `$params` filled in."""
        key, op = self.substitute(node.get("key"), scope, spec, node), node.get("op")
        value = self.substitute(node.get("value"), scope, spec, node)
        try:
            base, parts = split_key(str(key))
            if base not in self._keys:
                self.error(node, f"unknown blackboard key {base!r}", spec.path, "key",
                           did_you_mean(base, self._keys))
            elif problem := key_problem(base, parts):
                self.error(node, problem[0], spec.path, "key", problem[1])
        except ValueError as exc:
            self.error(node, str(exc), spec.path, "key")
        if op not in ALL_OPS:
            self.error(node, f"unknown op {op!r}; use one of {', '.join(ALL_OPS)}", spec.path, "op",
                       did_you_mean(op, ALL_OPS))
        elif op != "exists" and "value" not in node:
            self.error(node, f"op {op!r} needs a 'value'", spec.path, "op")
        if not finite(value):
            self.error(node, f"'value' must hold finite numbers only, got {short(value)}", spec.path, "value")
        return {"key": key, "op": op, "value": value}

    def units(self, spec: NodeSpec, node: Located, scope: Scope, declared: Mapping[str, Param]) -> None:
        """Each `$param` given to a param declared with a unit carries the same unit: a subtree param
        declared `unit: ms` passed into a param in s is refused, never converted (the value would
        mean another thing in each place), with the value in the unit the param takes."""
        given, outer = node.get("params"), self.subtrees.get(scope.subtrees[-1]) if scope.subtrees else None
        if not isinstance(given, Located) or outer is None:
            return
        for key, value in given.items():
            if not (isinstance(value, str) and value.startswith("$")):
                continue
            name = value[1:]
            source, target = outer.params.get(name), declared.get(key)
            if source is None or target is None or not source.unit or not target.unit or source.unit == target.unit:
                continue
            hint = f"declare ${name} with unit {target.unit!r}"
            factor = UNIT_FACTORS.get((source.unit, target.unit))
            number = scope.params.get(name)
            if factor is not None and isinstance(number, (int, float)) and not isinstance(number, bool):
                hint += f" and give it {number * factor:g} ({number:g} {source.unit} = {number * factor:g} {target.unit})"
            self.error(given, f"param {key!r} takes {target.unit}, but ${name} is declared in {source.unit} "
                       f"by subtree {outer.name!r}", spec.path, key, hint)

    def device_ranges(self, spec: NodeSpec, node: Located, declared: Mapping[str, Param], values: dict) -> None:
        """Each param bound to a device range (`Param.device`) within the cell's range, at its own line."""
        if self.cell is None:
            return
        given = node.get("params")
        for key, param in declared.items():
            value, limit = values.get(key), self.cell.ranges.get(param.device)
            if limit is None or isinstance(value, bool) or not isinstance(value, (int, float)) or limit.contains(value):
                continue
            where = given if isinstance(given, Located) and key in given else node
            what, consequence = DEVICE_RANGES[param.device]
            self.error(where, f"param {key!r} = {value:g} {param.unit} is outside the {what} range of cell "
                       f"{self.cell.name}, [{limit.low:g}, {limit.high:g}] {limit.unit}, from {limit.source}",
                       spec.path, key if where is given else "params",
                       f"{consequence}; keep it within {limit.high:g} {limit.unit}, or validate for the cell that "
                       "runs the tree (--cell CELL)")

    def params(self, spec: NodeSpec, node: Located, scope: Scope) -> dict:
        """The node's `params` mapping with `$params` filled in (unchecked: the kind checks it)."""
        params = node.get("params", {}) or {}
        if not isinstance(params, dict):
            self.error(node, f"'params' must be a mapping, got {short(params)}", spec.path, "params")
            return {}
        return {k: self.substitute(v, scope, spec, node) for k, v in params.items()}

    def substitute(self, value: Any, scope: Scope, spec: NodeSpec, node: Located) -> Any:
        """`value` with a `$param` string (or `$param` list items) replaced by the param's value."""
        if isinstance(value, str) and value.startswith("$"):
            if value[1:] in scope.params:
                return scope.params[value[1:]]
            known = f"its params: {', '.join(scope.params)}" if scope.params else "only subtrees take $params"
            self.error(node, f"{value} is not a parameter of the enclosing subtree", spec.path,
                       hint=did_you_mean(value[1:], scope.params) or known)
            return None
        if isinstance(value, list):
            return [self.substitute(v, scope, spec, node) for v in value]
        return value


def finite(value: Any) -> bool:
    """Whether every number in a value from a file (nested lists and mappings included) is finite."""
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, (list, tuple)):
        return all(finite(v) for v in value)
    if isinstance(value, dict):
        return all(finite(v) for v in value.values())
    return True


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
        line = raw.line_of(pname) if isinstance(raw, Located) else where.line_of("params")
        if isinstance(decl, str):
            decl = {"type": decl}
        ptype = decl.get("type") if isinstance(decl, dict) else None
        if ptype not in PARAM_TYPES:
            errors.append(TreeError(f"param {pname!r}: type must be one of {', '.join(PARAM_TYPES)}",
                                    where.file, line, f"subtrees/{name}", did_you_mean(ptype, PARAM_TYPES)))
            continue
        extra = set(decl) - set(PARAM_FIELDS)
        if extra:
            errors.append(TreeError(f"param {pname!r}: unknown field {min(extra)!r}", where.file,
                                    line, f"subtrees/{name}", did_you_mean(min(extra), PARAM_FIELDS)))
        text = next((key for key in ("doc", "unit") if not isinstance(decl.get(key, ""), str)), None)
        if text:
            errors.append(TreeError(f"param {pname!r}: {text} must be a string, got {short(decl[text])}",
                                    where.file, line, f"subtrees/{name}"))
        param = Param(ptype, decl.get("doc", ""), decl.get("default", REQUIRED), decl.get("unit", ""))
        if not param.required:
            try:
                param = replace(param, default=param.check(param.default))
            except ValueError as exc:
                errors.append(TreeError(f"param {pname!r}: default: {exc}", where.file, line, f"subtrees/{name}"))
                continue
        out[pname] = param
    return out
