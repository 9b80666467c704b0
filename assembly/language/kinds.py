"""The node kinds of the YAML tree language, one table entry each.

An entry (a `NodeKind`, defined in `assembly.language.validator`) says everything about a kind: its fields
(with the JSON Schema of their values) and which are required, how to check them into a
`NodeSpec`, how to build the py_trees behaviour, how `fvtree show` labels it and a one-line doc.
The validator, `build()`, `tree_schema()` and `fvtree show` all read `NODE_KINDS`, so a new kind
is one entry here (see `tests/test_node_kinds.py`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import ParallelPolicy, Status

from assembly.language.validator import COMMON_FIELDS, NodeKind, NodeSpec, Scope, Validator, finite, short
from assembly.nodes import composites, decorators
from assembly.nodes.conditions import ALL_OPS, Condition, split_key
from assembly.nodes.decorators import CellTimeout, Guard, StatusMap
from assembly.nodes.for_each_element import ForEachElement
from behaviours.skill_kit.base import Param
from behaviours.skill_kit.keys import TASK_KEYS
from behaviours.skill_kit.model_files import check_model
from behaviours.skill_kit.registry import SKILLS
from fvfiles.errors import did_you_mean
from fvfiles.yaml_source import Located
from perception.learning.models import ModelError

STATUSES = {"success": Status.SUCCESS, "failure": Status.FAILURE, "running": Status.RUNNING}
POLICIES = ("all", "one", "selected")

# JSON Schema of field values shared by several kinds (NODE: a child node).
NODE: dict[str, Any] = {"$ref": "#/$defs/node"}
CHILDREN: dict[str, Any] = {"type": "array", "items": NODE, "minItems": 1}
BOOLEAN: dict[str, Any] = {"type": "boolean"}
STRING: dict[str, Any] = {"type": "string"}
CONDITION_FIELDS: dict[str, dict[str, Any]] = {
    "key": {"type": "string", "pattern": "^/"}, "op": {"enum": list(ALL_OPS)}, "value": {}}
SCHEMA_DEFS = {"condition": {"type": "object", "required": ["key", "op"], "additionalProperties": False,
                             "properties": CONDITION_FIELDS}}


# ---- checks: each reads its kind's fields into spec.args -----------------------------------------
def _one_child(validator: Validator, spec: NodeSpec, node: Located, scope: Scope) -> None:
    validator.children(spec, node, scope, "child")


def _composite(validator, spec, node, scope) -> None:
    spec.args["memory"] = validator.flag(spec, node, "memory")
    validator.children(spec, node, scope)


def _parallel(validator, spec, node, scope) -> None:
    policy = node["policy"]
    if policy not in POLICIES:
        validator.error(node, f"policy must be one of {', '.join(POLICIES)}, got {policy!r}",
                        spec.path, "policy", did_you_mean(policy, POLICIES))
    spec.args["policy"] = policy
    spec.args["synchronise"] = validator.flag(spec, node, "synchronise") if "synchronise" in node else False
    validator.children(spec, node, scope)
    selected = node.get("selected")
    if policy == "selected":
        names = [c.name for c in spec.children]
        if not isinstance(selected, list) or not selected:
            validator.error(node, "policy 'selected' needs 'selected: [child names]'", spec.path, "policy")
        else:
            for s in selected:
                if s not in names:
                    validator.error(node, f"selected child {s!r} is not a child of this parallel",
                                    spec.path, "selected", did_you_mean(s, names))
        spec.args["selected"] = selected or []
    elif selected is not None:
        validator.error(node, "'selected' only applies to policy 'selected'", spec.path, "selected")


def _retry(validator, spec, node, scope) -> None:
    spec.args["attempts"] = validator.count(spec, node, "attempts", 1)
    _one_child(validator, spec, node, scope)


def _repeat(validator, spec, node, scope) -> None:
    spec.args["times"] = validator.count(spec, node, "times", 1, allow_forever=True)
    _one_child(validator, spec, node, scope)


def _timeout(validator, spec, node, scope) -> None:
    seconds = node["seconds"]
    if not isinstance(seconds, (int, float)) or isinstance(seconds, bool) or not finite(seconds) or seconds <= 0:
        validator.error(node, f"'seconds' must be a positive finite number, got {short(seconds)}", spec.path,
                        "seconds")
    spec.args["seconds"] = seconds
    _one_child(validator, spec, node, scope)


def _status_map(validator, spec, node, scope) -> None:
    mapping = node["map"]
    if not isinstance(mapping, dict) or not mapping:
        validator.error(node, "'map' must map statuses, e.g. {failure: success}", spec.path, "map")
    else:
        for k, v in mapping.items():
            for s in (k, v):
                if not isinstance(s, str) or s not in STATUSES:
                    validator.error(node, f"unknown status {s!r} in 'map'", spec.path, "map",
                                    did_you_mean(s, STATUSES) or f"use {', '.join(STATUSES)}")
    spec.args["map"] = dict(mapping) if isinstance(mapping, dict) else {}
    _one_child(validator, spec, node, scope)


def _guard(validator, spec, node, scope) -> None:
    cond = node["while"]
    if isinstance(cond, Located):
        spec.args["while"] = validator.condition(spec, cond, scope)
    else:
        validator.error(node, "'while' must be a condition mapping {key, op, value}", spec.path, "while")
    _one_child(validator, spec, node, scope)


def _for_each_element(validator, spec, node, scope) -> None:
    if not validator.has_design:
        validator.error(node, "for_each_element needs a design model", spec.path, "for_each_element",
                        "add 'design: path/to/model.json' at the top of the tree file")
    elements = node.get("elements")
    if elements is not None and (not isinstance(elements, list) or not all(isinstance(e, str) for e in elements)):
        validator.error(node, f"'elements' must be a list of element ids, got {short(elements)}", spec.path,
                        "elements")
    elif elements is not None and validator.element_ids is not None:
        for eid in elements:
            if eid not in validator.element_ids:
                validator.error(node, f"element {eid!r} is not in the design", spec.path, "elements",
                                did_you_mean(eid, validator.element_ids) or
                                f"its elements: {', '.join(sorted(validator.element_ids))}")
    spec.args["elements"] = elements
    _one_child(validator, spec, node, scope)


def _condition(validator, spec, node, scope) -> None:
    spec.args.update(validator.condition(spec, node, scope))


def _skill(validator, spec, node, scope) -> None:
    """Params are checked here, once, against the skill's declaration; `build` takes them as they are."""
    cls = SKILLS.get(spec.type)
    if cls is None:
        validator.error(node, f"unknown skill {spec.type!r}", spec.path, "skill",
                        did_you_mean(spec.type, SKILLS) or "run 'fvtree skills' to list them")
        return
    params = validator.params(spec, node, scope)
    unknown = [key for key in params if key not in cls.PARAMS]
    for key in unknown:
        validator.error(node, f"unknown param {key!r} for skill {spec.type!r}", spec.path, "params",
                        did_you_mean(key, cls.PARAMS) or f"known: {', '.join(cls.PARAMS) or 'none'}")
    if unknown:
        return
    validator.units(spec, node, scope, cls.PARAMS)
    try:
        spec.args["params"] = check_model(cls, cls.resolve_params(params), params, spec.file)
        validator.device_ranges(spec, node, cls.PARAMS, spec.args["params"])
    except ModelError as exc:
        validator.error(node, f"param 'model': {exc.message}", spec.path, "params")
    except ValueError as exc:
        validator.error(node, str(exc), spec.path, "params")


def _subtree(validator, spec, node, scope) -> None:
    """The subtree's declared params are checked here; its body is validated with their values."""
    ref = spec.type
    definition = validator.subtrees.get(ref)
    if definition is None:
        validator.error(node, f"unknown subtree {ref!r}", spec.path, "subtree",
                        did_you_mean(ref, validator.subtrees) or "define it under 'subtrees:' or include its file")
        return
    if ref in scope.subtrees:
        chain = " -> ".join(scope.subtrees[scope.subtrees.index(ref):] + (ref,))
        validator.error(node, f"recursive subtree: {chain}", spec.path, "subtree")
        return
    given = validator.params(spec, node, scope)
    values = {}
    before = len(validator.errors)
    validator.units(spec, node, scope, definition.params)
    for key in given:
        if key not in definition.params:
            validator.error(node, f"unknown param {key!r} for subtree {ref!r}", spec.path, "params",
                            did_you_mean(key, definition.params) or
                            f"known: {', '.join(definition.params) or 'none'}")
    for key, decl in definition.params.items():
        if key in given:
            try:
                values[key] = decl.check(given[key])
            except ValueError as exc:
                validator.error(node, f"param {key!r}: {exc}", spec.path, "params")
        elif decl.required:
            validator.error(node, f"missing param {key!r} for subtree {ref!r}", spec.path, "subtree")
        else:
            values[key] = decl.default
    if len(validator.errors) > before:
        return  # the body would only repeat the parameter problems
    body = validator.node(definition.root, spec.path, scope.enter(ref, values), (definition.file, definition.line))
    if body is not None:
        spec.children.append(body)


# ---- builds ---------------------------------------------------------------------------------------
def _build_parallel(spec: NodeSpec, kids: list[Behaviour]) -> Behaviour:
    a = spec.args
    policy: ParallelPolicy.Base
    if a["policy"] == "all":
        policy = ParallelPolicy.SuccessOnAll(synchronise=a["synchronise"])
    elif a["policy"] == "one":
        policy = ParallelPolicy.SuccessOnOne()
    else:
        chosen = [k for k in kids if k.name in a["selected"]]
        policy = ParallelPolicy.SuccessOnSelected(children=chosen, synchronise=a["synchronise"])
    return py_trees.composites.Parallel(name=spec.name, policy=policy, children=kids)


def _build_guard(spec: NodeSpec, kids: list[Behaviour]) -> Behaviour:
    c = spec.args["while"]
    return Guard(spec.name, kids[0], Condition(f"{spec.name}?", c["key"], c["op"], c["value"]))


# ---- labels for `fvtree show` ---------------------------------------------------------------------
def _label_with(field: str) -> Callable[[NodeSpec], str]:
    return lambda spec: f"[{spec.kind} {field}={spec.args[field]}]"


def _condition_reads(c: dict) -> tuple[str, ...]:
    """The key a condition reads, which something ticking before it must write (dataflow): none for
    `exists`, which asks whether it has been written."""
    return () if c["op"] == "exists" else (split_key(str(c["key"]))[0],)


def _label_condition(c: dict) -> str:
    return f"{c['key']} {c['op']} {c['value']!r}"


def _label_skill(spec: NodeSpec) -> str:
    params = ", ".join(f"{k}={v}" for k, v in spec.args.get("params", {}).items())
    return f"[skill {spec.type}]" + (f" ({params})" if params else "")


# ---- JSON Schema of skill nodes: one variant per skill, with its typed params ------------------------
def param_schema(p: Param) -> dict:
    """JSON Schema of one declared skill param (type, range, choices, unit, default)."""
    if p.type == "vector":
        s: dict[str, Any] = {"type": "array", "items": {"type": "number"}}
        if p.length:
            s["minItems"] = s["maxItems"] = p.length
        items = s["items"]
    else:
        s = {"type": {"float": "number", "int": "integer", "bool": "boolean", "str": "string"}[p.type]}
        items = s
    if p.min is not None:
        items["minimum"] = p.min
    if p.max is not None:
        items["maximum"] = p.max
    if p.choices:
        s["enum"] = list(p.choices)
    s["description"] = p.doc + (f" [{p.unit}]" if p.unit else "")
    if not p.required and p.default is not None:
        s["default"] = p.default
    return s


def _skill_variants(name: str, kind: NodeKind) -> list[dict]:
    variants = []
    for skill, cls in sorted(SKILLS.items()):
        params = {k: {"anyOf": [param_schema(p), {"type": "string", "pattern": r"^\$"}]}
                  for k, p in cls.PARAMS.items()}
        props = {name: {"const": skill}, **kind.fields, **COMMON_FIELDS,
                 "params": {"type": "object", "additionalProperties": False, "properties": params}}
        variants.append({"type": "object", "required": [name], "additionalProperties": False,
                         "properties": props, "description": cls.SUMMARY})
    return variants


def _decorator(doc: str, build: Callable[[NodeSpec, list[Behaviour]], Behaviour],
               fields: Mapping[str, dict] | None = None, check=_one_child, **more: Any) -> NodeKind:
    """A decorator kind: one `child` plus the given fields, all required."""
    fields = {**(fields or {}), "child": NODE}
    return NodeKind(doc, fields, frozenset(fields), check, build, **more)


def _memory_label(spec: NodeSpec) -> str:
    return f"[{spec.kind}, memory={str(spec.args['memory']).lower()}]"


def _required_reads(cls) -> tuple[str, ...]:
    """The keys a skill reads that something must write before it (not those read with a fallback)."""
    return tuple(k for k in cls.READS if k not in cls.OPTIONAL_READS)


def _composite_kind(cls: type, until: str) -> NodeKind:
    """The node kind of a sequence or a selector (`cls`), whose memory is always explicit."""
    return NodeKind(
        doc=f"ticks the children in order until one {until}; `memory: true` resumes at the running one",
        fields={"memory": BOOLEAN, "children": CHILDREN}, required=frozenset({"memory", "children"}),
        check=_composite, label=_memory_label,
        build=lambda spec, kids: cls(name=spec.name, memory=spec.args["memory"], children=kids))


NODE_KINDS: dict[str, NodeKind] = {
    "sequence": _composite_kind(composites.Sequence, "does not succeed"),
    "selector": _composite_kind(composites.Selector, "does not fail"),
    "parallel": NodeKind(
        doc="ticks every child; succeeds on all, one, or the selected children",
        fields={"policy": {"enum": list(POLICIES)}, "children": CHILDREN, "synchronise": BOOLEAN,
                "selected": {"type": "array", "items": STRING}},
        required=frozenset({"policy", "children"}), check=_parallel, build=_build_parallel,
        label=_label_with("policy"), concurrent=True),
    "retry": _decorator(
        doc="fails after `attempts` failures of the child",
        fields={"attempts": {"type": "integer", "minimum": 1}}, check=_retry, label=_label_with("attempts"),
        build=lambda spec, kids: decorators.Retry(
            name=spec.name, child=kids[0], num_failures=spec.args["attempts"])),
    "repeat": _decorator(
        doc="succeeds after `times` successes of the child (-1: for ever)",
        fields={"times": {"type": "integer", "minimum": -1}}, check=_repeat, label=_label_with("times"),
        build=lambda spec, kids: decorators.Repeat(
            name=spec.name, child=kids[0], num_success=spec.args["times"])),
    "timeout": _decorator(
        doc="fails (halting the child) after `seconds` of cell time",
        fields={"seconds": {"type": "number", "exclusiveMinimum": 0}}, check=_timeout,
        label=_label_with("seconds"),
        build=lambda spec, kids: CellTimeout(spec.name, kids[0], float(spec.args["seconds"]))),
    "inverter": _decorator(
        doc="swaps success and failure",
        build=lambda spec, kids: decorators.Inverter(name=spec.name, child=kids[0])),
    "status_map": _decorator(
        doc="maps the child's status, e.g. `map: {failure: success}`",
        fields={"map": {"type": "object", "propertyNames": {"enum": list(STATUSES)},
                        "additionalProperties": {"enum": list(STATUSES)}}},
        check=_status_map,
        build=lambda spec, kids: StatusMap(
            spec.name, kids[0], {STATUSES[k]: STATUSES[v] for k, v in spec.args["map"].items()})),
    "guard": _decorator(
        doc="ticks the child while a condition holds; halts it when the condition turns false",
        fields={"while": {"$ref": "#/$defs/condition"}}, check=_guard, build=_build_guard,
        label=lambda spec: f"[guard while {_label_condition(spec.args['while'])}]",
        substitutes=frozenset({"while"}), keys=lambda spec: (_condition_reads(spec.args["while"]), ())),
    "for_each_element": NodeKind(
        doc="runs the child once per unplaced design element, in build order, publishing it on /task/element",
        fields={"child": NODE, "elements": {"type": "array", "items": STRING}}, required=frozenset({"child"}),
        check=_for_each_element, publishes=frozenset(TASK_KEYS),
        build=lambda spec, kids: ForEachElement(spec.name, kids[0], spec.args["elements"])),
    "condition": NodeKind(
        doc="compares a blackboard value, `key op value`, e.g. `key: /fv/left.slip`",
        fields=CONDITION_FIELDS, required=frozenset({"key", "op"}), check=_condition,
        label=lambda spec: f"[condition {_label_condition(spec.args)}]",
        substitutes=frozenset({"key", "value"}), keys=lambda spec: (_condition_reads(spec.args), ()),
        build=lambda spec, kids: Condition(spec.name, spec.args["key"], spec.args["op"], spec.args["value"])),
    "skill": NodeKind(
        doc="a tactile skill; its params are checked against the skill's declaration",
        fields={"name": STRING, "params": {"type": "object"}}, required=frozenset(), check=_skill,
        label=_label_skill, value="TYPE", substitutes=frozenset({"params"}), variants=_skill_variants,
        keys=lambda spec: (_required_reads(SKILLS[spec.type]), SKILLS[spec.type].WRITES),
        build=lambda spec, kids: SKILLS[spec.type](spec.name, resolved=spec.args["params"])),
    "subtree": NodeKind(
        doc="an instance of a subtree; `$param` strings in its body take the given values",
        fields={"name": STRING, "params": {"type": "object"}}, required=frozenset(), check=_subtree,
        label=lambda spec: f"[subtree {spec.type}]", value="REF", substitutes=frozenset({"params"}),
        build=lambda spec, kids: decorators.PassThrough(name=spec.name, child=kids[0])),
}
