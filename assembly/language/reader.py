"""Read a tree file: top-level fields, includes, subtrees and the design model; the whole file is
validated before anything runs, into a `TreeDocument`."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from assembly.design.model import DesignModel
from assembly.errors import TreeError, TreeErrors
from assembly.language.dataflow import dataflow_errors
from assembly.language.fields import CELL_FIELDS, TOP_FIELDS, Field, required
from assembly.language.kinds import NODE_KINDS
from assembly.language.plugins import load_plugins
from assembly.language.validator import CellRanges, NodeSpec, Scope, SubtreeDef, Validator, subtree_params
from behaviours.skill_kit.keys import PERCEPTION_KEYS
from drivers.device_ranges import device_ranges
from fvfiles.errors import FvtreeError, did_you_mean, did_you_mean_field, field_name
from fvfiles.schema_check import schema_problem
from fvfiles.yaml_source import Located, LocatedList, load_file, load_text


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


def _top_level(doc: object, file: str, errors: list[TreeError], tree_file: bool) -> bool:
    """Check the fields of a tree (or, not `tree_file`, an included) file against their tables;
    False if it is not even a mapping."""
    if not isinstance(doc, Located):
        errors.append(TreeError("a tree file is a YAML mapping (version, name, root, ...)", file, 1))
        return False
    _FieldCheck(file, tree_file, errors).mapping(doc, TOP_FIELDS, "")
    return True


@dataclass
class _FieldCheck:
    """Checks the mappings of one file against their tables of fields (`assembly.language.fields`),
    each problem at its own line with the field's path."""

    file: str
    tree_file: bool  # the tree file loaded, not an included one (`fields.TREE_FILE`)
    errors: list[TreeError]

    def mapping(self, mapping: Located, table: Mapping[str, Field], where: str) -> None:
        """Each unknown field (with a did-you-mean), each missing one, and each value. `where` is the
        mapping's field path, "" at the top."""
        noun = "field" if where else "top-level field"
        for key, value in mapping.items():
            if key in table:
                self.value(value, table[key], f"{where}.{key}" if where else str(key), mapping.line_of(key))
            else:
                self.errors.append(TreeError(f"unknown {noun} {field_name(key)}", self.file, mapping.line_of(key),
                                             where or None, did_you_mean_field(key, table) or f"known: {', '.join(table)}"))
        for key in required(table, self.tree_file):
            if key not in mapping:
                self.errors.append(TreeError(f"missing {noun} {key!r}", self.file, mapping.line, where or None,
                                             table[key].doc))

    def value(self, value: object, field: Field, where: str, line: int) -> None:
        """A value against its field's schema, then its own fields or named entries, each at its own
        line; the insides of a value that code checks (`Field.checked_by`) are left to that code."""
        problem = schema_problem(value, field.schema)
        if problem:
            self.errors.append(TreeError(problem, self.file, line, where, field.doc))
        elif field.checked_by or not isinstance(value, Located):
            return
        elif field.fields is not None:
            self.mapping(value, field.fields, where)
        elif field.entries is not None:
            for name, entry in value.items():
                self.value(entry, field.entries, f"{where}.{name}", value.line_of(name))


def _fits(mapping: Located, key: str) -> bool:
    """`key` is a top-level field of `mapping` whose value fits its schema (a misfit is reported by
    `_FieldCheck`, and not read any further)."""
    return key in mapping and schema_problem(mapping[key], TOP_FIELDS[key].schema) is None


INCLUDE_PATH = "FVTREE_INCLUDE_PATH"  # more folders includes may come from (os.pathsep-separated)


def include_roots(tree_file: str) -> list[Path]:
    """The folders a tree's includes may come from: the tree file's own (with its subfolders) and
    each folder FVTREE_INCLUDE_PATH names (`fvtree --allow-include DIR` adds to it). A file
    elsewhere (`/etc/shadow`, `../../x.yaml`, a symbolic link leading out) is never opened."""
    extra = [Path(p).expanduser().resolve() for p in os.environ.get(INCLUDE_PATH, "").split(os.pathsep) if p]
    return [Path(tree_file).resolve().parent, *extra]


def _collect_subtrees(doc: Located, file: str, out: dict[str, SubtreeDef], errors: list[TreeError],
                      seen_files: tuple[str, ...], roots: list[Path]) -> None:
    """Subtrees of this file and, recursively, of its includes (their fields are checked with the
    top level: here the include cycles, the subtrees defined twice, the param declarations and
    that each include lies under one of `roots`)."""
    base = Path(file).parent
    includes: LocatedList = (doc["include"] or LocatedList()) if _fits(doc, "include") else LocatedList()
    for i, rel in enumerate(includes):
        line = includes.item_lines[i]
        try:
            target = str((base / rel).resolve())
        except (RuntimeError, OSError) as exc:  # a symbolic-link loop (RuntimeError before Python 3.13)
            errors.append(TreeError(f"include {rel!r}: cannot be resolved ({exc})", file, line))
            continue
        if not any(Path(target).is_relative_to(root) for root in roots):
            errors.append(TreeError(f"include {rel!r}: outside the tree's folder {roots[0]}, so it is not read",
                                    file, line, hint="allow its folder with `fvtree --allow-include DIR ...` "
                                                     f"or {INCLUDE_PATH}=DIR"))
            continue
        if target in seen_files:
            errors.append(TreeError(f"include cycle: {' -> '.join(seen_files + (target,))}", file, line))
            continue
        try:
            sub = load_file(base / rel)
        except FvtreeError as exc:
            errors.append(TreeError(f"include {rel!r}: {exc.message}", exc.file or file,
                                    exc.line or line))
            continue
        if _top_level(sub, str(base / rel), errors, tree_file=False):
            _collect_subtrees(sub, str(base / rel), out, errors, seen_files + (target,), roots)
    subtrees: Located = (doc["subtrees"] or Located()) if _fits(doc, "subtrees") else Located()
    for name, body in subtrees.items():
        if not isinstance(body, Located) or "root" not in body:
            continue  # reported with the fields
        line = subtrees.line_of(name)
        if name in out:
            errors.append(TreeError(f"subtree {name!r} is defined twice", file, line,
                                    hint=f"also in {out[name].file}:{out[name].line}"))
            continue
        params = body.get("params") if isinstance(body.get("params"), dict) else None
        out[name] = SubtreeDef(name, subtree_params(params, body, name, errors), body["root"], file, line)


def _cell_settings(doc: Located, file: str, errors: list[TreeError]) -> tuple[float, str]:
    """The tree's tick rate and simulated scene (their values are checked with the fields; here
    that the simulator knows the scene)."""
    cell = doc["cell"] if isinstance(doc.get("cell"), Located) else Located()
    scene = cell.get("scene", CELL_FIELDS["scene"].schema["default"])
    if isinstance(scene, str) and scene not in _scenes():
        errors.append(TreeError(f"no simulated scene {scene!r}", file, cell.line_of("scene"), "cell.scene",
                                did_you_mean(scene, _scenes()) or f"known: {', '.join(sorted(_scenes()))}"))
    return cell.get("tick_hz", CELL_FIELDS["tick_hz"].schema["default"]), scene


def with_scene(doc: TreeDocument, scene: str) -> TreeDocument:
    """The tree with another simulated scene (`fvtree run --scene`), which must exist."""
    if scene not in _scenes():
        raise TreeError(f"--scene {scene}: no simulated scene {scene!r}", doc.path,
                        hint=did_you_mean(scene, _scenes()) or f"known: {', '.join(sorted(_scenes()))}")
    return replace(doc, scene=scene)


def _design(doc: Located, file: str, errors: list[TreeError]) -> DesignModel | None:
    """The design model the tree names (relative to the tree file), if any."""
    if not _fits(doc, "design"):
        return None  # none, or not a path (reported with the fields)
    try:
        return DesignModel.load(Path(file).parent / str(doc["design"]))
    except FvtreeError as exc:
        if exc.line:  # a place in the design file
            errors.append(TreeError(f"design: {exc.message}", exc.file, exc.line, hint=exc.hint))
        else:  # the design file as a whole: point at the tree's `design:` line
            errors.append(TreeError(f"design {exc.file}: {exc.message}", file, doc.line_of("design"),
                                    hint=exc.hint))
        return None


def _scene_file(design: DesignModel, errors: list[TreeError]) -> None:
    """The scene file next to the design (`<design>.scene.yaml`: the plates' loads in simulation),
    checked against the design's plates now rather than when the simulated scene is built."""
    if design.path is None:
        return
    from drivers.sim.scenes.scene_file import plate_loads, scene_file_of

    spans = {pid: float(plate["span"]) for pid, plate in design.plates().items()}
    try:
        plate_loads(scene_file_of(design.path), spans)
    except FvtreeError as exc:
        errors.append(TreeError(f"scene file: {exc.message}", exc.file, exc.line, exc.field, exc.hint))


def load_tree(path: str | Path | None = None, text: str | None = None, name: str = "<tree>",
              dataflow: bool = True, cell: str | None = None) -> TreeDocument:
    """Parse and validate a tree file (or `text`); raises TreeErrors listing every problem.
    `dataflow` also refuses a node that reads a blackboard key nothing ticking before it writes
    (off for tests that put the keys on the blackboard by hand). `cell` (a cell file or packaged
    cell's name) also checks the params bound to a device range against that cell's devices."""
    load_plugins()
    file = str(path) if path is not None else name
    try:
        doc = load_text(text, file) if text is not None else load_file(file)
    except FvtreeError as exc:
        raise TreeErrors([exc]) from None
    errors: list[TreeError] = []
    if not _top_level(doc, file, errors, tree_file=True):
        raise TreeErrors(errors)
    tick_hz, scene = _cell_settings(doc, file, errors)
    design = _design(doc, file, errors)
    if design is not None:
        _scene_file(design, errors)
    subtrees: dict[str, SubtreeDef] = {}
    _collect_subtrees(doc, file, subtrees, errors, (str(Path(file).resolve()),), include_roots(file))
    root = None
    if "root" in doc:
        validator = Validator(NODE_KINDS, subtrees, has_design="design" in doc,
                              element_ids=None if design is None else design.elements(),
                              cell=None if cell is None else CellRanges(cell, device_ranges(cell)))
        root = validator.node(doc["root"], "", Scope(), (file, doc.line_of("root")))
        errors.extend(validator.errors)
        if dataflow and not validator.errors and root is not None:
            errors.extend(dataflow_errors(root, NODE_KINDS, PERCEPTION_KEYS))
    if errors or root is None:  # no root without an error saying why
        raise TreeErrors(errors)
    tolerances = (doc.get("cell") or {}).get("tolerances") or Located()
    return TreeDocument(file, str(doc["name"]), float(tick_hz), scene, design, root, subtrees, tolerances)
