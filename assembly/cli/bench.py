"""`fvtree bench NAME`: run one of the benchmarks, each of which writes a table and a chart."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

from assembly.cli.args import POSITIVE_INT, Subparsers
from assembly.cli.exits import EXIT_USAGE

BENCHES = {
    "ticks": "assembly.bench.ticks",
    "perception": "assembly.bench.perception",
    "drivers": "assembly.bench.drivers",
    "skills": "assembly.bench.skills",
    "recording": "assembly.bench.recording_cost",
    "demos": "assembly.bench.demos",
    "seeds": "assembly.bench.seeds",
    "robustness": "assembly.bench.robustness",
    "validate": "assembly.bench.validate",
}
SWEEP = ("seeds", "modes", "trees", "jobs")  # the options of the benchmarks that sweep demo trees
TICKS = ("seeds", "parts")  # `fvtree bench ticks`'s own


def add_commands(sub: Subparsers) -> None:
    """`fvtree bench`."""
    b = sub.add_parser("bench", help="benchmarks that write a table and a chart")
    b.add_argument("name", choices=sorted(BENCHES))
    b.add_argument("--out", help="output directory (default: bench/NAME)")
    b.add_argument("--quick", action="store_true", help="a short run for smoke tests")
    b.add_argument("--seeds", type=POSITIVE_INT, help="robustness: seeds 0..N-1 per tree and mode (default 20); "
                   "ticks: per simulation option and mode (default 3)")
    b.add_argument("--modes", nargs="+", choices=("signals", "pixels"), help="robustness: perception modes "
                   "(default both)")
    b.add_argument("--trees", nargs="+", help="robustness: demo trees by name, e.g. hold assembly (default all)")
    b.add_argument("--jobs", type=POSITIVE_INT, default=1, help="robustness: runs at a time (default 1)")
    b.add_argument("--parts", nargs="+", choices=("ticks", "options", "costs"), help="ticks: which parts to measure "
                   "(default all: tick parts; speed against accuracy per simulation option; per-tick cost of each "
                   "check and model)")
    b.set_defaults(func=cmd_bench)


def cmd_bench(args) -> int:
    own = {"robustness": SWEEP, "ticks": TICKS}.get(args.name, ())
    given = [name for name in (*SWEEP, "parts") if getattr(args, name) not in (None, 1) and name not in own]
    if given:
        print(f"fvtree bench: --{', --'.join(given)} do not apply to `fvtree bench {args.name}` (--seeds, --modes, "
              "--trees, --jobs: robustness; --seeds, --parts: ticks)", file=sys.stderr)
        return EXIT_USAGE
    module = importlib.import_module(BENCHES[args.name])
    out = Path(args.out or f"bench/{args.name}")
    out.mkdir(parents=True, exist_ok=True)
    options = {name: getattr(args, name) for name in own if getattr(args, name) is not None}
    for path in module.run(out, quick=args.quick, **options):
        print(f"wrote {path}")
    return 0
