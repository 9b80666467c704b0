"""`fvtree bench NAME`: run one of the benchmarks, each of which writes a table and a chart."""

from __future__ import annotations

import importlib
from pathlib import Path

from assembly.cli.args import Subparsers

BENCHES = {
    "ticks": "assembly.bench.ticks",
    "perception": "assembly.bench.perception",
    "drivers": "assembly.bench.drivers",
    "skills": "assembly.bench.skills",
    "recording": "assembly.bench.recording_cost",
    "demos": "assembly.bench.demos",
    "seeds": "assembly.bench.seeds",
    "validate": "assembly.bench.validate",
}


def add_commands(sub: Subparsers) -> None:
    """`fvtree bench`."""
    b = sub.add_parser("bench", help="benchmarks that write a table and a chart")
    b.add_argument("name", choices=sorted(BENCHES))
    b.add_argument("--out", help="output directory (default: bench/NAME)")
    b.add_argument("--quick", action="store_true", help="a short run for smoke tests")
    b.set_defaults(func=cmd_bench)


def cmd_bench(args) -> int:
    module = importlib.import_module(BENCHES[args.name])
    out = Path(args.out or f"bench/{args.name}")
    out.mkdir(parents=True, exist_ok=True)
    for path in module.run(out, quick=args.quick):
        print(f"wrote {path}")
    return 0
