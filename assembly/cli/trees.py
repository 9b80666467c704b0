"""The commands that check and document trees without running them: `fvtree validate` (also designs
and cell files), `show`, `skills`, `scenes` and `schema`."""

from __future__ import annotations

import json
from pathlib import Path

from assembly.cli.args import Subparsers
from assembly.cli.exits import EXIT_USAGE, report
from fvfiles.errors import FvtreeError

DEFAULT_CELL = "sim"  # the cell a tree is validated for unless --cell names one: the one `fvtree run` uses


def add_commands(sub: Subparsers) -> None:
    """`fvtree validate`, `show`, `skills`, `scenes` and `schema`."""
    v = sub.add_parser("validate", help="check tree, design (.json) or cell files without running or connecting")
    v.add_argument("files", nargs="*", metavar="FILE",
                   help="trees, designs (.json) and cell files (a mapping with `kind:`, checked whole: types, "
                        "finite values, home inside the safety box, without touching a device)")
    v.add_argument("--cell", metavar="CELL", default=None,
                   help="check the trees' device params (gripper force and width, arm speeds, TCP force) against "
                        f"this cell's ranges, and the cell file whole (default: {DEFAULT_CELL}, the cell `fvtree run` "
                        "uses)")
    v.set_defaults(func=cmd_validate)

    s = sub.add_parser("show", help="print a tree with its nodes' kinds, params and statuses")
    s.add_argument("tree")
    s.add_argument("--run", help="a run directory whose final statuses to show")
    s.set_defaults(func=cmd_show)

    k = sub.add_parser("skills", help="list every skill with its params and blackboard keys")
    k.add_argument("--json", action="store_true")
    k.set_defaults(func=cmd_skills)

    sc = sub.add_parser("scenes", help="list the simulated scenes: what each simulates, its params, the demo "
                                       "trees that use it")
    sc.add_argument("--json", action="store_true")
    sc.set_defaults(func=cmd_scenes)

    j = sub.add_parser("schema", help="JSON Schema of the tree language, for editors")
    j.add_argument("--out", help="write to this file instead of stdout")
    j.set_defaults(func=cmd_schema)


def _load(path: str):
    """The tree at `path`, loaded and checked (a located FvtreeError if it is not a valid tree)."""
    from assembly.language.reader import load_tree

    return load_tree(path)


def _walk(spec):
    """Every node of the tree under `spec`, itself first."""
    yield spec
    for child in spec.children:
        yield from _walk(child)


def _is_cell_file(path: str) -> bool:
    """Whether a YAML file is a cell file: a mapping with a `kind` and neither a tree's `version`
    nor its `root` (a file that cannot be read is left to the tree reader to report)."""
    from fvfiles.yaml_source import load_file

    try:
        doc = load_file(path)
    except FvtreeError:
        return False
    return isinstance(doc, dict) and "kind" in doc and not {"version", "root"} & set(doc)


def _validate_cell(name: str) -> str:
    """Check a cell file whole, touching no device; what it holds, or a located FvtreeError."""
    from drivers.cell_builders import validate

    spec = validate(name)
    return f"cell {spec['name']!r}, kind {spec['kind']}"


def _validate_file(path: str, cell: str) -> str:
    """Check one input file whole, touching no device: a cell file, a design model (`.json`) or a
    tree, whose device params are checked against `cell`; returns what it holds, or raises a
    located FvtreeError."""
    if Path(path).suffix == ".json":
        from assembly.design.model import DesignModel

        design = DesignModel.load(path)
        return f"design, {len(design.elements())} elements on {len(design.plates())} plates"
    from assembly.errors import TreeErrors
    from assembly.language.reader import load_tree

    try:
        doc = load_tree(path, cell=cell)
    except TreeErrors:
        if _is_cell_file(path):  # asked only of a file that is no tree: a tree is read once
            return _validate_cell(path)
        raise
    return f"{doc.name}, {sum(1 for _ in _walk(doc.root))} nodes, for cell {cell}"


def cmd_validate(args) -> int:
    if not args.files and args.cell is None:
        raise FvtreeError("nothing to validate", hint="give tree, design or cell files, or --cell CELL")
    if args.cell is not None:
        try:
            print(f"{args.cell}: ok ({_validate_cell(args.cell)})")
        except FvtreeError as exc:  # no tree can be checked against a cell that does not hold together
            return report(exc)
    bad = 0
    for path in args.files:
        try:
            what = _validate_file(path, args.cell or DEFAULT_CELL)
        except FvtreeError as exc:
            bad += 1
            report(exc)
            continue
        print(f"{path}: ok ({what})")
    return EXIT_USAGE if bad else 0


def cmd_show(args) -> int:
    from assembly.outcome.outline import render

    print(render(_load(args.tree), Path(args.run) if args.run else None))
    return 0


def cmd_skills(args) -> int:
    from assembly.language.catalogue import describe_skills, skills_table

    if args.json:
        print(json.dumps(describe_skills(), indent=1))
    else:
        print(skills_table())
    return 0


def cmd_scenes(args) -> int:
    from assembly.language.catalogue import describe_scenes, scenes_table

    if args.json:
        print(json.dumps(describe_scenes(), indent=1))
    else:
        print(scenes_table(), end="")
    return 0


def cmd_schema(args) -> int:
    from assembly.language.schema import tree_schema

    text = json.dumps(tree_schema(), indent=1)
    if args.out:
        Path(args.out).write_text(text + "\n")
        print(f"wrote {args.out}")
    else:
        print(text)
    return 0
