"""`fvtree`: run, validate, show and document behaviour trees of tactile skills."""

from __future__ import annotations

import argparse
import importlib
import json
import logging
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from assembly.cli.design import add_design_link_commands, add_link_options
from assembly.observe import IMAGE_HZ
from fileio.errors import FvtreeError, FvtreeErrors

EXIT_FAILURE = 1  # the tree ran and failed, or a check failed
EXIT_USAGE = FvtreeError.exit_code  # bad input: a tree, design, cell or data file, or an argument

BENCHES = {
    "ticks": "assembly.bench.ticks",
    "perception": "assembly.bench.perception",
    "drivers": "assembly.bench.drivers",
    "skills": "assembly.bench.skills",
    "recording": "assembly.bench.recording_cost",
    "demos": "assembly.bench.demos",
    "seeds": "assembly.bench.seeds",
}


def _load(path: str):
    from assembly.language.reader import load_tree

    return load_tree(path)


def report(exc: FvtreeError) -> int:
    """Print a located error (each of them, for a list) on stderr; returns its exit code."""
    for err in exc.errors if isinstance(exc, FvtreeErrors) else [exc]:
        print(err, file=sys.stderr)
    return exc.exit_code


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


def _walk(spec):
    yield spec
    for child in spec.children:
        yield from _walk(child)


RUN_EXIT = {"SUCCESS": 0, "FAULT": 3, "CRASHED": 4, "TASK_FAILED": 5}  # any other result: EXIT_FAILURE


def _substitution_rules(texts: list[str], files: list[str]) -> list:
    """The --substitute rules, then those of each --substitute-file, in order."""
    from assembly.language.substitution import load_rules, parse_rule

    return [parse_rule(t) for t in texts] + [rule for f in files for rule in load_rules(f)]


def cmd_run(args) -> int:
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


def run_options(args: argparse.Namespace):
    """The `RunOptions` of `fvtree run`'s arguments."""
    from assembly.run.options import LinkOptions, RunOptions

    if (args.coordinated or args.cell_name) and not args.bridge:
        raise FvtreeError("--coordinated and --cell-name name this cell on a broker", args.tree,
                          hint="add --bridge mqtt://HOST:PORT")
    link = LinkOptions(args.bridge, args.cell_name, args.coordinated) if args.bridge else None
    return RunOptions(
        cell=args.cell, seed=args.seed, perception=args.perception, scene=args.scene,
        realtime=args.speed == "realtime", max_time=args.max_time, estop_at=args.estop_at,
        runs_dir=Path(args.runs_dir), resume=args.resume, marks=dict(args.mark), record=not args.no_record,
        record_images=args.record_images, plots=not args.no_plots, link=link,
        substitutions=tuple(_substitution_rules(args.substitute, args.substitute_file)))


def _mark(text: str) -> tuple[str, str]:
    """argparse type: ELEMENT=placed|planned."""
    element, _, status = text.partition("=")
    if not element or status not in ("placed", "planned"):
        raise argparse.ArgumentTypeError(f"expected ELEMENT=placed or ELEMENT=planned, got {text!r}")
    return element, status


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


def _write_or_print(text: str, out: str | None) -> None:
    if out:
        Path(out).write_text(text)
        print(f"wrote {out}")
    else:
        print(text, end="")


def cmd_export(args) -> int:
    if (args.format or ("mcap" if Path(args.tree).is_dir() or not Path(args.tree).suffix else "btcpp")) == "mcap":
        from assembly.interop.mcap.export import export_mcap

        out, counts = export_mcap(Path(args.tree), Path(args.out) if args.out else None)
        print(f"wrote {out}: {sum(counts.values())} messages on {len(counts)} topics")
        return 0
    from assembly.interop.btcpp import export_tree

    _write_or_print(export_tree(args.tree, Path(args.out).parent if args.out else Path("."), args.subtree_models),
                    args.out)
    return 0


def cmd_import(args) -> int:
    from assembly.interop.btcpp import import_xml

    _write_or_print(import_xml(args.xml, args.out or "imported.yaml"), args.out)
    return 0


def cmd_view(args) -> int:
    from assembly.observe.replay import view

    return view(Path(args.run_dir), web=not args.native, web_port=args.web_port, grpc_port=args.port)


def cmd_sensor(args) -> int:
    from assembly.observe.sensor_view import sensor_view

    seen = sensor_view(args.source, Path(args.map), args.preset, args.finger, args.frames,
                       Path(args.save) if args.save else None, not args.no_view, args.image_every)
    print(f"{seen['frames']} frames, {seen['unhealthy']} unhealthy, {seen.get('markers', 0)} markers in the map")
    return 0


def cmd_bench(args) -> int:
    module = importlib.import_module(BENCHES[args.name])
    out = Path(args.out or f"bench/{args.name}")
    out.mkdir(parents=True, exist_ok=True)
    for path in module.run(out, quick=args.quick):
        print(f"wrote {path}")
    return 0


def cmd_check(args) -> int:
    from drivers.check import check_cell

    results = check_cell(args.cell)
    for device, ok, detail in results:
        print(f"{'OK  ' if ok else 'FAIL'} {device}: {detail}")
    return 0 if all(ok for _, ok, _ in results) else EXIT_FAILURE


def cmd_record(args) -> int:
    from assembly.dataset_recorder import record

    print(f"wrote {record(args.tree, args.out, cell=args.cell, seed=args.seed, runs=args.runs, perception=args.perception)}")
    return 0


def cmd_import_log(args) -> int:
    from perception.learning.blobmoves import import_logs

    rec = import_logs(args.logs)
    print(f"wrote {rec.save(args.out)} ({len(args.logs)} trials, {len(rec)} frames)")
    return 0


def cmd_train(args) -> int:
    from perception.learning.train import run

    if args.test and args.kind != "stir":
        raise FvtreeError("--test (a recording of another session) is for StirLearn (`fvtree train stir`)",
                          args.test)
    for path in run(args.kind, args.data, args.out, seed=args.seed, test=args.test):
        print(f"wrote {path}")
    return 0


def _number(convert: Callable[[str], float], minimum: float, strict: bool) -> Callable[[str], float]:
    """argparse type: a number of at least `minimum` (above it when `strict`)."""

    def parse(text: str) -> float:
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {convert.__name__}, got {text!r}") from None
        if value < minimum or (strict and value == minimum):
            raise argparse.ArgumentTypeError(f"must be {'>' if strict else '>='} {minimum}, got {text}")
        return value

    return parse


def _existing_file(text: str) -> str:
    """argparse type: a path to a file that exists."""
    if not Path(text).is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text}")
    return text


SEED = _number(int, 0, strict=False)
POSITIVE_INT = _number(int, 1, strict=False)
POSITIVE = _number(float, 0, strict=True)
NON_NEGATIVE = _number(float, 0, strict=False)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fvtree", description=__doc__)
    p.add_argument("--debug", action="store_true", help="show tracebacks and debug logs")
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("run", help="run a tree on a cell (the simulated one by default)")
    r.add_argument("tree")
    r.add_argument("--cell", default="sim", help="cell file or packaged cell name (default: sim)")
    r.add_argument("--seed", type=SEED, default=0, help="seed of the simulated world's noise")
    r.add_argument("--speed", choices=("realtime", "max"), default="max",
                   help="simulated time: as fast as possible (max) or paced to the wall clock")
    r.add_argument("--perception", choices=("signals", "pixels"), default=None,
                   help="simulated FingerVision: from contact signals, or rendered frames through the pipeline")
    r.add_argument("--scene", default=None, metavar="NAME",
                   help="simulate this scene instead of the tree's `cell.scene` (see `fvtree scenes`)")
    r.add_argument("--runs-dir", default="runs", help="where run directories go (default: runs)")
    r.add_argument("--resume", nargs="?", const="latest", default=None, metavar="RUN_DIR",
                   help="continue a run, skipping elements already placed (default: the latest run)")
    r.add_argument("--estop-at", type=NON_NEGATIVE, default=None, metavar="SECONDS",
                   help="simulate an e-stop at this cell time")
    r.add_argument("--max-time", type=POSITIVE, default=3600.0, metavar="SECONDS",
                   help="give up after this much cell time")
    r.add_argument("--no-plots", action="store_true", help="skip the PNG charts")
    r.add_argument("--no-record", action="store_true", help="do not write the run's recording (recording.rrd)")
    r.add_argument("--record-images", type=NON_NEGATIVE, default=IMAGE_HZ, metavar="HZ",
                   help="camera frames per second of cell time in the recording, when the cell has images "
                        f"(pixel perception, real cameras); 0: none (default: {IMAGE_HZ:g})")
    r.add_argument("--view", action="store_true",
                   help="stream the run live to a web viewer on 127.0.0.1 (kept serving until Ctrl-C)")
    r.add_argument("--mark", type=_mark, action="append", default=[], metavar="ELEMENT=placed|planned",
                   help="with --resume: after checking the cell, mark an element a stopped run left being "
                        "placed (placed: it stands; planned: build it again)")
    r.add_argument("--substitute", action="append", default=[], metavar="PATH=SPEC",
                   help="replace the node at PATH (or every node a glob matches; * crosses /) with a test double: "
                        "success, failure, running, running:N:success|failure, or skill:TYPE[:{json params}]")
    r.add_argument("--substitute-file", action="append", default=[], metavar="RULES.json",
                   help='substitutions from a JSON file {"PATH or glob": SPEC, ...}')
    add_link_options(r)
    r.set_defaults(func=cmd_run)

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

    ex = sub.add_parser("export", help="write a tree as BehaviorTree.CPP v4 XML, for Groot2 (docs/btcpp.md), or a "
                                       "run directory as an MCAP file, for Foxglove and ROS 2 tools")
    ex.add_argument("tree", metavar="TREE|RUN_DIR")
    ex.add_argument("--format", choices=("btcpp", "mcap"), default=None,
                    help="output format (default: mcap for a run directory or a path with no suffix, else btcpp)")
    ex.add_argument("-o", "--out", help="file to write (default: stdout; mcap: RUN_DIR/recording.mcap)")
    ex.add_argument("--subtree-models", action="store_true",
                    help="also declare the subtrees' ports in <TreeNodesModel> as Groot2 does (not valid against "
                         "BT.CPP's XSD)")
    ex.set_defaults(func=cmd_export)

    im = sub.add_parser("import", help="read BehaviorTree.CPP v4 XML (e.g. from Groot2) into a YAML tree")
    im.add_argument("xml")
    im.add_argument("-o", "--out", help="YAML file to write (default: stdout; paths then relative to the "
                                        "current directory)")
    im.set_defaults(func=cmd_import)

    vw = sub.add_parser("view", help="replay a run's recording in the Rerun viewer (web, on 127.0.0.1)")
    vw.add_argument("run_dir", metavar="RUN_DIR")
    vw.add_argument("--native", action="store_true", help="open the native viewer instead (needs a display)")
    vw.add_argument("--port", type=POSITIVE_INT, default=9876, help="gRPC port of the viewer server")
    vw.add_argument("--web-port", type=POSITIVE_INT, default=9090, help="port of the web viewer page")
    vw.set_defaults(func=cmd_view)

    sn = sub.add_parser("sensor", help="set up a FingerVision skin: live image, markers, calibration, health, "
                                       "wrench; saves the marker map")
    sn.add_argument("source", help="camera device index, video file, or MJPEG/RTSP URL")
    sn.add_argument("--map", default="marker_map.yaml", help="marker map file to write (default: marker_map.yaml)")
    sn.add_argument("--preset", default="fast", help="perception preset (default: fast)")
    sn.add_argument("--finger", choices=("left", "right"), default="right")
    sn.add_argument("--frames", type=POSITIVE_INT, default=None, help="stop after this many frames")
    sn.add_argument("--save", default=None, metavar="FILE.rrd", help="also write a recording")
    sn.add_argument("--image-every", type=POSITIVE_INT, default=1, metavar="N", help="send every N-th image")
    sn.add_argument("--no-view", action="store_true", help="no web viewer (with --save: record only)")
    sn.set_defaults(func=cmd_sensor)

    b = sub.add_parser("bench", help="benchmarks that write a table and a chart")
    b.add_argument("name", choices=sorted(BENCHES))
    b.add_argument("--out", help="output directory (default: bench/NAME)")
    b.add_argument("--quick", action="store_true", help="a short run for smoke tests")
    b.set_defaults(func=cmd_bench)

    c = sub.add_parser("check", help="connect to each device of a cell and report, moving nothing")
    c.add_argument("--cell", required=True)
    c.set_defaults(func=cmd_check)

    rec = sub.add_parser("record", help="run a tree and record per-tick tactile features and labels")
    rec.add_argument("tree")
    rec.add_argument("--out", required=True, help="recording file to write (.npz)")
    rec.add_argument("--cell", default="sim", help="cell file or packaged cell name (default: sim)")
    rec.add_argument("--seed", type=SEED, default=0, help="seed of the first run")
    rec.add_argument("--runs", type=POSITIVE_INT, default=1,
                     help="record this many runs (seeds seed, seed+1, ...)")
    rec.add_argument("--perception", choices=("signals", "pixels"), default=None,
                     help="simulated FingerVision: from contact signals, or rendered frames through the pipeline")
    rec.set_defaults(func=cmd_record)

    il = sub.add_parser("import-log", help="turn BlobMoves marker logs of other FingerVision software (one trial "
                                           "per JSON or YAML file) into a recording for fvtree train")
    il.add_argument("logs", nargs="+", type=_existing_file, metavar="LOG")
    il.add_argument("--out", required=True, help="recording file to write (.npz)")
    il.set_defaults(func=cmd_import_log)

    tr = sub.add_parser("train", help="train ForceLearn (force) or StirLearn (stir) on a recording")
    tr.add_argument("kind", choices=("force", "stir"))
    tr.add_argument("data", type=_existing_file, nargs="+", help="recordings made by fvtree record (joined)")
    tr.add_argument("--out", required=True, help="model file to write (.npz)")
    tr.add_argument("--seed", type=SEED, default=0)
    tr.add_argument("--test", type=_existing_file, default=None, metavar="RECORDING",
                    help="stir: test on every trial of this recording of another session (fvtree record "
                         "--seed N) instead of holding out trials of DATA")
    tr.set_defaults(func=cmd_train)
    add_design_link_commands(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.debug else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return args.func(args)
    except FvtreeError as exc:
        return report(exc)
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM outside a tick loop (which halts the run itself)
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # last resort: one line unless --debug
        if args.debug:
            raise
        if isinstance(exc, OSError) and exc.filename is not None:  # a path given on the command line
            return report(FvtreeError(exc.strerror or str(exc), str(exc.filename)))
        print(f"error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback)", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":
    sys.exit(main())
