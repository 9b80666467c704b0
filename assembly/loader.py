"""Load a tree file: top-level fields, includes, subtrees and the design model; validate the
whole file before anything runs; build the py_trees tree with a stable path per node."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import py_trees
from py_trees.common import ParallelPolicy, Status

from assembly.conditions import Condition
from assembly.decorators import CellTimeout, Guard, StatusMap
from assembly.design import DesignModel
from assembly.errors import TreeError, TreeErrors, did_you_mean
from assembly.iteration import ForEachElement
from assembly.language import NodeSpec, SubtreeDef, Validator, subtree_params
from assembly.yaml_source import Located, load_file, load_text
from behaviours.registry import SKILLS

TOP_FIELDS = {"version", "name", "doc", "cell", "design", "include", "subtrees", "root"}
CELL_FIELDS = {"tick_hz": (int, float), "scene": (str,)}
SUPPORTED_VERSIONS = (1,)
_STATUS = {"success": Status.SUCCESS, "failure": Status.FAILURE, "running": Status.RUNNING}


@dataclass
class TreeDocument:
    """A validated tree file."""

    path: str
    name: str
    tick_hz: float
    scene: str
    design: DesignModel | None
    root: NodeSpec
    subtrees: dict[str, SubtreeDef] = field(default_factory=dict)


def _top_level(doc, file: str, errors: list[TreeError], need_root: bool) -> None:
    if not isinstance(doc, Located):
        raise TreeErrors([TreeError("a tree file is a YAML mapping (version, name, root, ...)", file, 1)])
    for key in doc:
        if key not in TOP_FIELDS:
            errors.append(TreeError(f"unknown top-level field {key!r}", file, doc.line_of(key),
                                    hint=did_you_mean(key, TOP_FIELDS)))
    if doc.get("version") not in SUPPORTED_VERSIONS:
        errors.append(TreeError(f"'version' must be one of {SUPPORTED_VERSIONS}, got {doc.get('version')!r}",
                                file, doc.line_of("version")))
    required = ("name", "root") if need_root else ()
    for key in required:
        if key not in doc:
            errors.append(TreeError(f"missing top-level field {key!r}", file, doc.line))


def _collect_subtrees(doc: Located, file: str, out: dict[str, SubtreeDef], errors: list[TreeError],
                      seen_files: tuple[str, ...]) -> None:
    """Subtrees of this file and, recursively, of its includes."""
    base = Path(file).parent
    includes = doc.get("include", []) or []
    if not isinstance(includes, list):
        errors.append(TreeError("'include' must be a list of files", file, doc.line_of("include")))
        includes = []
    for i, rel in enumerate(includes):
        line = includes.item_lines[i] if hasattr(includes, "item_lines") else doc.line_of("include")
        target = str((base / str(rel)).resolve())
        if target in seen_files:
            errors.append(TreeError(f"include cycle: {' -> '.join(seen_files + (target,))}", file, line))
            continue
        try:
            sub = load_file(base / str(rel))
        except TreeError as exc:
            errors.append(TreeError(f"include {rel!r}: {exc.message}", exc.file or file,
                                    exc.line or line))
            continue
        _top_level(sub, str(base / str(rel)), errors, need_root=False)
        if isinstance(sub, Located):
            _collect_subtrees(sub, str(base / str(rel)), out, errors, seen_files + (target,))
    subtrees = doc.get("subtrees", {}) or {}
    if not isinstance(subtrees, dict):
        errors.append(TreeError("'subtrees' must map names to {params, root}", file, doc.line_of("subtrees")))
        return
    for name, body in subtrees.items():
        line = subtrees.line_of(name) if isinstance(subtrees, Located) else doc.line
        if name in out:
            errors.append(TreeError(f"subtree {name!r} is defined twice", file, line,
                                    hint=f"also in {out[name].file}:{out[name].line}"))
            continue
        if not isinstance(body, Located) or "root" not in body:
            errors.append(TreeError(f"subtree {name!r} needs a 'root' node", file, line))
            continue
        for key in body:
            if key not in ("params", "root", "doc"):
                errors.append(TreeError(f"unknown field {key!r} in subtree {name!r}", file,
                                        body.line_of(key), hint=did_you_mean(key, ("params", "root", "doc"))))
        params = subtree_params(body.get("params"), body, name, errors)
        out[name] = SubtreeDef(name, params, body["root"], file, line)


def load_tree(path: str | Path | None = None, text: str | None = None, name: str = "<tree>") -> TreeDocument:
    """Parse and validate a tree file (or `text`); raises TreeErrors listing every problem."""
    file = str(path) if path is not None else name
    try:
        doc = load_file(path) if text is None else load_text(text, file)
    except TreeError as exc:
        raise TreeErrors([exc]) from None
    errors: list[TreeError] = []
    _top_level(doc, file, errors, need_root=True)
    cell = doc.get("cell", {}) or {}
    if not isinstance(cell, dict):
        errors.append(TreeError("'cell' must be a mapping", file, doc.line_of("cell")))
        cell = {}
    for key, value in cell.items():
        if key not in CELL_FIELDS:
            errors.append(TreeError(f"unknown cell setting {key!r}", file, cell.line_of(key),
                                    hint=did_you_mean(key, CELL_FIELDS)))
        elif not isinstance(value, CELL_FIELDS[key]) or isinstance(value, bool):
            errors.append(TreeError(f"cell.{key} has the wrong type: {value!r}", file, cell.line_of(key)))
    tick_hz = cell.get("tick_hz", 30)
    if isinstance(tick_hz, (int, float)) and not 0 < tick_hz <= 1000:
        errors.append(TreeError(f"cell.tick_hz must be in (0, 1000], got {tick_hz}", file, cell.line_of("tick_hz")))
    design = None
    if "design" in doc:
        design_path = Path(file).parent / str(doc["design"])
        try:
            design = DesignModel.load(design_path)
        except TreeError as exc:
            errors.append(TreeError(f"design: {exc.message}", exc.file, exc.line or None, hint=exc.hint))
    subtrees: dict[str, SubtreeDef] = {}
    _collect_subtrees(doc, file, subtrees, errors, (str(Path(file).resolve()),))
    root = None
    if "root" in doc:
        validator = Validator(subtrees, has_design=design is not None or "design" in doc)
        root = validator.node(doc["root"], "", {}, ())
        errors.extend(validator.errors)
    if errors:
        raise TreeErrors(errors)
    return TreeDocument(file, str(doc["name"]), float(tick_hz), str(cell.get("scene", "assembly")),
                        design, root, subtrees)


# ---- building ---------------------------------------------------------------------------------
@dataclass
class BuiltTree:
    """The py_trees tree of a document, with every node addressable by its path."""

    document: TreeDocument
    root: py_trees.behaviour.Behaviour
    nodes: dict[str, py_trees.behaviour.Behaviour]  # path -> node

    def path_of(self, node: py_trees.behaviour.Behaviour) -> str:
        return self._paths[node.id]

    def __post_init__(self):
        self._paths = {node.id: path for path, node in self.nodes.items()}


def build(doc: TreeDocument) -> BuiltTree:
    nodes: dict[str, py_trees.behaviour.Behaviour] = {}

    def make(spec: NodeSpec) -> py_trees.behaviour.Behaviour:
        kids = [make(c) for c in spec.children]
        a = spec.args
        if spec.kind == "sequence":
            node = py_trees.composites.Sequence(name=spec.name, memory=a["memory"], children=kids)
        elif spec.kind == "selector":
            node = py_trees.composites.Selector(name=spec.name, memory=a["memory"], children=kids)
        elif spec.kind == "parallel":
            if a["policy"] == "all":
                policy = ParallelPolicy.SuccessOnAll(synchronise=a["synchronise"])
            elif a["policy"] == "one":
                policy = ParallelPolicy.SuccessOnOne()
            else:
                chosen = [k for k in kids if k.name in a["selected"]]
                policy = ParallelPolicy.SuccessOnSelected(children=chosen, synchronise=a["synchronise"])
            node = py_trees.composites.Parallel(name=spec.name, policy=policy, children=kids)
        elif spec.kind == "retry":
            node = py_trees.decorators.Retry(name=spec.name, child=kids[0], num_failures=a["attempts"])
        elif spec.kind == "repeat":
            node = py_trees.decorators.Repeat(name=spec.name, child=kids[0], num_success=a["times"])
        elif spec.kind == "timeout":
            node = CellTimeout(spec.name, kids[0], float(a["seconds"]))
        elif spec.kind == "inverter":
            node = py_trees.decorators.Inverter(name=spec.name, child=kids[0])
        elif spec.kind == "status_map":
            mapping = {_STATUS[k]: _STATUS[v] for k, v in a["map"].items()}
            node = StatusMap(spec.name, kids[0], mapping)
        elif spec.kind == "guard":
            c = a["while"]
            node = Guard(spec.name, kids[0], Condition(f"{spec.name}?", c["key"], c["op"], c["value"]))
        elif spec.kind == "for_each_element":
            node = ForEachElement(spec.name, kids[0], a.get("elements"))
        elif spec.kind == "condition":
            node = Condition(spec.name, a["key"], a["op"], a["value"])
        elif spec.kind == "skill":
            node = SKILLS[spec.type](spec.name, resolved=a["params"])
        elif spec.kind == "subtree":
            node = py_trees.decorators.PassThrough(name=spec.name, child=kids[0])
        else:  # pragma: no cover - the validator knows every kind
            raise AssertionError(spec.kind)
        nodes[spec.path] = node
        return node

    root = make(doc.root)
    return BuiltTree(doc, root, nodes)
