"""Benchmarks: `fvtree bench NAME` runs `assembly.bench.NAME.run(out, quick)`; `script` lets a
benchmark module run on its own as `python -m assembly.bench...`."""

from __future__ import annotations

import argparse
import csv
from collections.abc import Callable, Sequence
from pathlib import Path


def script(prog: str, run: Callable[[Path, bool], list[Path]], default_out: str, quick_help: str,
           description: str | None = None, argv: list[str] | None = None) -> int:
    """Parse `--out DIR [--quick]`, run the benchmark and print what it wrote."""
    parser = argparse.ArgumentParser(prog=prog, description=description)
    parser.add_argument("--out", type=Path, default=Path(default_out), help="output directory")
    parser.add_argument("--quick", action="store_true", help=quick_help)
    args = parser.parse_args(argv)
    for path in run(args.out, args.quick):
        print(f"wrote {path}")
    return 0


def write_csv(path: Path, rows: Sequence[dict], fieldnames: Sequence[str] | None = None) -> Path:
    """Write `rows` as a CSV table at `path` (columns: `fieldnames`, else the first row's keys)."""
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(fieldnames or rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return path
