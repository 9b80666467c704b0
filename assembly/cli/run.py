"""`fvtree run`: run a tree on a cell (the simulated one by default) and exit with its result."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from assembly.cli.args import (
    NON_NEGATIVE,
    POSITIVE,
    SEED,
    Subparsers,
    add_cell_option,
    add_perception_option,
    element_mark,
)
from assembly.cli.design import add_link_options
from assembly.cli.exits import EXIT_FAILURE
from assembly.observe import IMAGE_HZ
from fvfiles.errors import FvtreeError

if TYPE_CHECKING:  # the language and the run load on first use: `fvtree --help` stays quick
    from assembly.language.substitution import Rule
    from assembly.run.options import RunOptions

GROOT2_DEFAULT_PORT = 1667  # BT.CPP's Groot2Publisher default
RUN_EXIT = {"SUCCESS": 0, "FAULT": 3, "CRASHED": 4, "TASK_FAILED": 5}  # any other result: EXIT_FAILURE


def add_commands(sub: Subparsers) -> None:
    """`fvtree run` with its options, in the order its help lists them."""
    r = sub.add_parser("run", help="run a tree on a cell (the simulated one by default)")
    r.add_argument("tree")
    _add_world_options(r)
    _add_session_options(r)
    _add_output_options(r)
    _add_override_options(r)
    add_link_options(r)
    r.set_defaults(func=cmd_run)


def _add_world_options(r: argparse.ArgumentParser) -> None:
    """The cell and, when simulated, its noise, pace, perception and scene."""
    add_cell_option(r)
    r.add_argument("--seed", type=SEED, default=0, help="seed of the simulated world's noise")
    r.add_argument("--speed", choices=("realtime", "max"), default=None,
                   help="simulated time: as fast as possible (max, the default) or paced to the wall clock "
                        "(realtime, the default with --groot2)")
    add_perception_option(r)
    r.add_argument("--scene", default=None, metavar="NAME",
                   help="simulate this scene instead of the tree's `cell.scene` (see `fvtree scenes`)")


def _add_session_options(r: argparse.ArgumentParser) -> None:
    """Where the run directory goes, which run to resume, and when the run stops short."""
    r.add_argument("--runs-dir", default="runs", help="where run directories go (default: runs)")
    r.add_argument("--resume", nargs="?", const="latest", default=None, metavar="RUN_DIR",
                   help="continue a run, skipping elements already placed (default: the latest run)")
    r.add_argument("--estop-at", type=NON_NEGATIVE, default=None, metavar="SECONDS",
                   help="simulate an e-stop at this cell time")
    r.add_argument("--max-time", type=POSITIVE, default=3600.0, metavar="SECONDS",
                   help="give up after this much cell time")


def _add_output_options(r: argparse.ArgumentParser) -> None:
    """What the run writes and shows besides its logs: charts, recording, live view."""
    r.add_argument("--no-plots", action="store_true", help="skip the PNG charts")
    r.add_argument("--no-record", action="store_true", help="do not write the run's recording (recording.rrd)")
    r.add_argument("--record-images", type=NON_NEGATIVE, default=IMAGE_HZ, metavar="HZ",
                   help="camera frames per second of cell time in the recording, when the cell has images "
                        f"(pixel perception, real cameras); 0: none (default: {IMAGE_HZ:g})")
    r.add_argument("--view", action="store_true",
                   help="stream the run live to a web viewer on 127.0.0.1 (kept serving until Ctrl-C)")
    r.add_argument("--groot2", nargs="?", type=groot2_port, const=GROOT2_DEFAULT_PORT, default=None, metavar="PORT",
                   help="serve the run to Groot2 (BehaviorTree.CPP's monitor protocol over ZeroMQ) on PORT "
                        f"and PORT+1 (default {GROOT2_DEFAULT_PORT}); needs pyzmq and msgpack")
    r.add_argument("--groot2-address", default="127.0.0.1", metavar="ADDRESS",
                   help="the address --groot2 listens on (default 127.0.0.1, this machine only; "
                        "0.0.0.0: every interface)")


def groot2_port(text: str) -> int:
    """argparse type: a TCP port whose next port is one too."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a port number, got {text!r}") from None
    if not 1 <= port <= 65534:
        raise argparse.ArgumentTypeError(f"must be 1..65534 (it and the next port are used), got {text}")
    return port


def _add_override_options(r: argparse.ArgumentParser) -> None:
    """What the run takes as given over the tree and the run directory: elements' marks, test doubles."""
    r.add_argument("--mark", type=element_mark, action="append", default=[], metavar="ELEMENT=placed|planned",
                   help="with --resume: after checking the cell, mark an element a stopped run left being "
                        "placed (placed: it stands; planned: build it again)")
    r.add_argument("--substitute", action="append", default=[], metavar="PATH=SPEC",
                   help="replace the node at PATH (or every node a glob matches; * crosses /) with a test double: "
                        "success, failure, running, running:N:success|failure, or skill:TYPE[:{json params}]")
    r.add_argument("--substitute-file", action="append", default=[], metavar="RULES.json",
                   help='substitutions from a JSON file {"PATH or glob": SPEC, ...}')


def _substitution_rules(texts: list[str], files: list[str]) -> list[Rule]:
    """The --substitute rules, then those of each --substitute-file, in order."""
    from assembly.language.substitution import load_rules, parse_rule

    return [parse_rule(t) for t in texts] + [rule for f in files for rule in load_rules(f)]


def cmd_run(args: argparse.Namespace) -> int:
    from assembly.observe.replay import live_view
    from assembly.run.session import run_tree

    options = run_options(args)  # bad arguments are refused before a viewer starts
    with live_view(args.view, say=lambda line: print(line, file=sys.stderr)) as viewer:
        summary = run_tree(args.tree, replace(options, live=viewer.grpc) if viewer else options)
    if summary.nothing_to_do:
        return 0
    if args.debug and summary.traceback:
        print(summary.traceback, file=sys.stderr, end="")
    return RUN_EXIT.get(summary.status, EXIT_FAILURE)


def run_options(args: argparse.Namespace) -> RunOptions:
    """The `RunOptions` of `fvtree run`'s arguments."""
    from assembly.run.options import LinkOptions, RunOptions

    linked = (args.coordinated, args.cell_name, args.credentials, args.tls_ca, args.tls_cert, args.tls_key, args.unsigned)
    if any(linked) and not args.bridge:
        raise FvtreeError("--coordinated, --cell-name, --credentials, --tls-* and --unsigned set up a link to a broker",
                          args.tree, hint="add --bridge mqtt://HOST:PORT")
    def path(name: str | None) -> Path | None:
        return None if name is None else Path(name)

    link = LinkOptions(args.bridge, args.cell_name, args.coordinated, path(args.credentials), path(args.tls_ca),
                       path(args.tls_cert), path(args.tls_key), args.link_lost_after, args.unsigned) if args.bridge else None
    return RunOptions(
        cell=args.cell, seed=args.seed, perception=args.perception, scene=args.scene,
        realtime=(args.speed or ("realtime" if args.groot2 else "max")) == "realtime", max_time=args.max_time,
        estop_at=args.estop_at,
        runs_dir=Path(args.runs_dir), resume=args.resume, marks=dict(args.mark), record=not args.no_record,
        record_images=args.record_images, plots=not args.no_plots, link=link,
        substitutions=tuple(_substitution_rules(args.substitute, args.substitute_file)),
        groot2=None if args.groot2 is None else (args.groot2_address, args.groot2))
