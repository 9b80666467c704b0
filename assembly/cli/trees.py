"""The commands that check and document trees without running them: `fvtree validate` (also designs
and cell files), `show`, `skills`, `scenes` and `schema`."""

from __future__ import annotations

import json
from pathlib import Path

from assembly.cli.args import Subparsers
from assembly.cli.exits import EXIT_USAGE, report
from fvfiles.errors import FvtreeError


def add_commands(sub: Subparsers) -> None:
    """`fvtree validate`, `show`, `skills`, `scenes` and `schema`."""
    v = sub.add_parser("validate", help="check tree, design (.json) or cell files without running or connecting")
    v.add_argument("files", nargs="+", metavar="FILE")
    v.add_argument("--cell", action="store_true",
                   help="the files are cell files: check them whole (types, finite values, home inside the "
                        "safety box) without touching a device")
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


def _validate_file(path: str, cell: bool) -> str:
    """Check one input file whole, touching no device: a cell file (`cell`), a design model
    (`.json`) or a tree; returns what it holds, or raises a located FvtreeError."""
    if cell:
        from drivers.cell_builders import validate

        spec = validate(path)
        return f"cell {spec['name']!r}, kind {spec['kind']}"
    if Path(path).suffix == ".json":
        from assembly.design.model import DesignModel

        design = DesignModel.load(path)
        return f"design, {len(design.elements())} elements on {len(design.plates())} plates"
    doc = _load(path)
    return f"{doc.name}, {sum(1 for _ in _walk(doc.root))} nodes"


def cmd_validate(args) -> int:
    bad = 0
    for path in args.files:
        try:
            what = _validate_file(path, args.cell)
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
