"""Read a tree file: top-level fields, includes, subtrees and the design model; the whole file is
validated before anything runs, into a `TreeDocument`."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

from assembly.design.model import DesignModel
from assembly.errors import TreeError, TreeErrors
from assembly.language.dataflow import dataflow_errors
from assembly.language.kinds import NODE_KINDS
from assembly.language.plugins import load_plugins
from assembly.language.validator import NodeSpec, Scope, SubtreeDef, Validator, short, subtree_params
from behaviours.skill_kit.keys import PERCEPTION_KEYS
from fileio.errors import FvtreeError, did_you_mean
from fileio.yaml_source import Located, load_file, load_text

TOP_FIELDS = {"version", "name", "doc", "cell", "design", "include", "subtrees", "root"}
CELL_FIELDS = {"tick_hz": (int, float), "scene": (str,), "tolerances": (dict,)}
SUPPORTED_VERSIONS = (1,)
SUBTREE_FIELDS = ("params", "root", "doc")


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
    tolerances: Located = field(default_factory=Located)  # name -> limit of the simulated verdict


def _scenes() -> dict:
    """The simulated scenes a tree may name (imported when a tree is loaded: the sims are large)."""
    from drivers.sim.scenes import SCENES

    return SCENES


def _top_level(doc: object, file: str, errors: list[TreeError], need_root: bool) -> bool:
    """Check the top-level fields of a tree (or included) file; False if it is not even a mapping."""
    if not isinstance(doc, Located):
        errors.append(TreeError("a tree file is a YAML mapping (version, name, root, ...)", file, 1))
        return False
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
    for key in ("name", "design"):
        if key in doc and (not isinstance(doc[key], str) or not doc[key]):
            errors.append(TreeError(f"'{key}' must be a non-empty string, got {short(doc[key])}", file,
                                    doc.line_of(key)))
    return True


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
        except FvtreeError as exc:
            errors.append(TreeError(f"include {rel!r}: {exc.message}", exc.file or file,
                                    exc.line or line))
            continue
        if _top_level(sub, str(base / str(rel)), errors, need_root=False):
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
            if key not in SUBTREE_FIELDS:
                errors.append(TreeError(f"unknown field {key!r} in subtree {name!r}", file,
                                        body.line_of(key), hint=did_you_mean(key, SUBTREE_FIELDS)))
        params = subtree_params(body.get("params"), body, name, errors)
        out[name] = SubtreeDef(name, params, body["root"], file, line)


def _cell_settings(doc: Located, file: str, errors: list[TreeError]) -> tuple[float, str]:
    """The tree's `cell:` settings (tick rate, simulated scene), checked."""
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
    scene = cell.get("scene", "assembly")
    if isinstance(scene, str) and scene not in _scenes():
        errors.append(TreeError(f"no simulated scene {scene!r}", file, cell.line_of("scene"), "cell.scene",
                                did_you_mean(scene, _scenes()) or f"known: {', '.join(sorted(_scenes()))}"))
    tolerances = cell.get("tolerances")
    for name, value in tolerances.items() if isinstance(tolerances, dict) else ():
        if not isinstance(value, (int, float)) or isinstance(value, bool) or value < 0:
            errors.append(TreeError(f"cell.tolerances.{name} must be a number >= 0, got {value!r}", file,
                                    tolerances.line_of(name)))
    tick_hz = cell.get("tick_hz", 30)
    if isinstance(tick_hz, (int, float)) and not 0 < tick_hz <= 1000:
        errors.append(TreeError(f"cell.tick_hz must be in (0, 1000], got {tick_hz}", file,
                                cell.line_of("tick_hz")))
    return tick_hz, scene


def with_scene(doc: TreeDocument, scene: str) -> TreeDocument:
    """The tree with another simulated scene (`fvtree run --scene`), which must exist."""
    if scene not in _scenes():
        raise TreeError(f"--scene {scene}: no simulated scene {scene!r}", doc.path,
                        hint=did_you_mean(scene, _scenes()) or f"known: {', '.join(sorted(_scenes()))}")
    return replace(doc, scene=scene)


def _design(doc: Located, file: str, errors: list[TreeError]) -> DesignModel | None:
    """The design model the tree names (relative to the tree file), if any."""
    if not isinstance(doc.get("design"), str):
        return None  # none, or not a path (reported with the top-level fields)
    try:
        return DesignModel.load(Path(file).parent / str(doc["design"]))
    except FvtreeError as exc:
        if exc.line:  # a place in the design file
            errors.append(TreeError(f"design: {exc.message}", exc.file, exc.line, hint=exc.hint))
        else:  # the design file as a whole: point at the tree's `design:` line
            errors.append(TreeError(f"design {exc.file}: {exc.message}", file, doc.line_of("design"),
                                    hint=exc.hint))
        return None


def load_tree(path: str | Path | None = None, text: str | None = None, name: str = "<tree>",
              dataflow: bool = True) -> TreeDocument:
    """Parse and validate a tree file (or `text`); raises TreeErrors listing every problem.
    `dataflow` also refuses a node that reads a blackboard key nothing ticking before it writes
    (off for tests that put the keys on the blackboard by hand)."""
    load_plugins()
    file = str(path) if path is not None else name
    try:
        doc = load_file(path) if text is None else load_text(text, file)
    except FvtreeError as exc:
        raise TreeErrors([exc]) from None
    errors: list[TreeError] = []
    if not _top_level(doc, file, errors, need_root=True):
        raise TreeErrors(errors)
    tick_hz, scene = _cell_settings(doc, file, errors)
    design = _design(doc, file, errors)
    subtrees: dict[str, SubtreeDef] = {}
    _collect_subtrees(doc, file, subtrees, errors, (str(Path(file).resolve()),))
    root = None
    if "root" in doc:
        validator = Validator(NODE_KINDS, subtrees, has_design="design" in doc,
                              element_ids=None if design is None else design.elements())
        root = validator.node(doc["root"], "", Scope(), (file, doc.line_of("root")))
        errors.extend(validator.errors)
        if dataflow and not validator.errors and root is not None:
            errors.extend(dataflow_errors(root, NODE_KINDS, PERCEPTION_KEYS))
    if errors:
        raise TreeErrors(errors)
    tolerances = (doc.get("cell") or {}).get("tolerances") or Located()
    return TreeDocument(file, str(doc["name"]), float(tick_hz), scene, design, root, subtrees, tolerances)
