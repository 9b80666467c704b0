"""The commands that trade with other tools: `fvtree export` (a tree as BehaviorTree.CPP XML, a run as
MCAP) and `fvtree import` (BehaviorTree.CPP XML into a YAML tree)."""

from __future__ import annotations

from pathlib import Path

from assembly.cli.args import Subparsers
from fvfiles.errors import FvtreeError


def add_commands(sub: Subparsers) -> None:
    """`fvtree export` and `fvtree import`."""
    ex = sub.add_parser("export", help="write a tree as BehaviorTree.CPP v4 XML, for Groot2 (docs/btcpp.md), or a "
                                       "run directory as an MCAP file, for Foxglove and ROS 2 tools")
    ex.add_argument("tree", metavar="TREE|RUN_DIR")
    ex.add_argument("--format", choices=("btcpp", "mcap"), default=None,
                    help="output format (default: mcap for a run directory or a path with no suffix, else btcpp)")
    ex.add_argument("-o", "--out", help="file to write (default: stdout; mcap: RUN_DIR/recording.mcap, with --ros2 "
                                        "RUN_DIR/recording.ros2.mcap)")
    ex.add_argument("--ros2", action="store_true",
                    help="mcap: a ROS 2 bag (standard message types in CDR, for ros2 bag play, rqt, Foxglove) "
                         "instead of Foxglove's JSON messages")
    ex.add_argument("--subtree-models", action="store_true",
                    help="also declare the subtrees' ports in <TreeNodesModel> as Groot2 does (not valid against "
                         "BT.CPP's XSD)")
    ex.set_defaults(func=cmd_export)

    im = sub.add_parser("import", help="read BehaviorTree.CPP v4 XML (e.g. from Groot2) into a YAML tree")
    im.add_argument("xml")
    im.add_argument("-o", "--out", help="YAML file to write (default: stdout; paths then relative to the "
                                        "current directory)")
    im.set_defaults(func=cmd_import)


def _write_or_print(text: str, out: str | None) -> None:
    """Write `text` to the file `out` and say so, or print it when no file is given."""
    if out:
        Path(out).write_text(text)
        print(f"wrote {out}")
    else:
        print(text, end="")


def cmd_export(args) -> int:
    if (args.format or ("mcap" if Path(args.tree).is_dir() or not Path(args.tree).suffix else "btcpp")) == "mcap":
        from assembly.interop.mcap.export import export_mcap

        out, counts = export_mcap(Path(args.tree), Path(args.out) if args.out else None, ros=args.ros2)
        print(f"wrote {out}: {sum(counts.values())} messages on {len(counts)} topics")
        return 0
    if args.ros2:
        raise FvtreeError("--ros2 writes a run as a ROS 2 bag (MCAP), not a tree", args.tree, field="--ros2",
                          hint="give a run directory, or drop --ros2")
    from assembly.interop.btcpp import export_tree

    _write_or_print(export_tree(args.tree, Path(args.out).parent if args.out else Path("."), args.subtree_models),
                    args.out)
    return 0


def cmd_import(args) -> int:
    from assembly.interop.btcpp import import_xml

    _write_or_print(import_xml(args.xml, args.out or "imported.yaml"), args.out)
    return 0
