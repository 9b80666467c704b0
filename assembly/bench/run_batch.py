"""Run one tree over several seeds in one process, as `fvtree run TREE --cell CELL --perception MODE
--seed N --no-plots --no-record` runs each: `python -m assembly.bench.run_batch TREE MODE CELL RUNS_DIR
SEED...` prints one JSON summary per seed (with its run directory), one per line.

A benchmark that sweeps seeds uses it to pay the interpreter's start-up (numpy, py_trees, the
pipeline; seconds on a loaded machine, against a fraction of a second for most demo runs) once per
tree instead of once per run; each run still builds its own cell, blackboard and tree.
"""

from __future__ import annotations

import json
import sys
import traceback
from pathlib import Path

from assembly.run.options import RunOptions
from assembly.run.session import run_tree


def run_seeds(tree: str, mode: str, cell: str, runs_dir: Path, seeds: list[int]) -> list[dict]:
    """The summary of each seed's run (status CRASHED with the traceback if the run raised)."""
    out = []
    for seed in seeds:
        where = runs_dir / str(seed)
        options = RunOptions(cell=cell, seed=seed, perception=mode, runs_dir=where, record=False, plots=False,
                             quiet=True)
        try:
            summary = run_tree(tree, options).to_json()
        except Exception as exc:  # noqa: BLE001 - one run's crash is that run's result, not the batch's
            summary = {"status": "CRASHED", "message": f"{type(exc).__name__}: {exc}",
                       "traceback": traceback.format_exc()}
        summary["seed"] = seed
        out.append(summary)
    return out


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    tree, mode, cell, runs_dir, *seeds = args
    for summary in run_seeds(tree, mode, cell, Path(runs_dir), [int(s) for s in seeds]):
        print(json.dumps(summary), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
