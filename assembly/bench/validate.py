"""`fvtree bench validate`: is `fvtree validate` quick enough to run on every save in an editor?

Each tree is validated `RUNS` times as its own process (`python -m assembly.cli validate TREE`, as an
editor's save hook would, with Python's bytecode cache on), after one warm-up run, timing the wall clock and reading the process's peak resident memory
(`os.wait4`); a further run lists which of the heavy libraries the process imported. Writes
validate.csv (tree, run, seconds, peak MB), validate.md (median, slowest, peak memory, heavy
imports, against the goal) and validate.png.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from assembly.bench import write_csv
from assembly.bench.demos import save

ROOT = Path(__file__).resolve().parents[2]
TREES = ("trees/assembly.yaml", "trees/hold.yaml", "trees/press_with_force.yaml")
RUNS, QUICK_RUNS = 11, 3
GOAL = 0.5  # s, the median on two cores
# Libraries a validation has no use for: each costs 0.1-2 s to import.
HEAVY = ("sklearn", "pandas", "scipy", "numba", "cv2", "rerun", "matplotlib", "networkx", "paho", "pymodbus")
_LIST_IMPORTS = ("import sys; from assembly.cli import main; main(['validate', sys.argv[1]]); "
                 f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules), file=sys.stderr)")


def _env() -> dict[str, str]:
    """The environment of a validation: this one, with Python's bytecode cache on (as an editor's Python
    has it), so the warm-up run leaves compiled modules for the timed ones."""
    return {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def validate_once(tree: str) -> tuple[float, float, float]:
    """(wall seconds, CPU seconds, peak resident MB) of one `fvtree validate TREE` process."""
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "assembly.cli", "validate", tree], cwd=ROOT, env=_env(),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    assert proc.stderr is not None
    problems = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here: keep Popen from waiting again
    if proc.returncode != 0:
        raise RuntimeError(f"fvtree validate {tree} failed: {problems.decode(errors='replace')}")
    return seconds, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0  # kB on Linux


def heavy_imports(tree: str) -> list[str]:
    """The heavy libraries a validation of `tree` imports."""
    done = subprocess.run([sys.executable, "-c", _LIST_IMPORTS, tree], cwd=ROOT, env=_env(), capture_output=True,
                          text=True, check=True)
    return done.stderr.split()


def run(out: Path, quick: bool = False) -> list[Path]:
    """Validate each tree RUNS times (QUICK_RUNS with --quick, the assembly tree only); write the table
    and the chart."""
    rows, heavy = [], {}
    for tree in TREES[:1] if quick else TREES:
        validate_once(tree)  # warm the file cache: an editor validates a tree it has just saved
        for i in range(QUICK_RUNS if quick else RUNS):
            seconds, cpu, mb = validate_once(tree)
            rows.append({"tree": tree, "run": i, "seconds": round(seconds, 4), "cpu_seconds": round(cpu, 4),
                         "peak_mb": round(mb, 1)})
        heavy[tree] = heavy_imports(tree)
    csv_path = write_csv(out / "validate.csv", rows, ["tree", "run", "seconds", "cpu_seconds", "peak_mb"])
    md_path = out / "validate.md"
    md_path.write_text(markdown(summary(rows), heavy))
    return [csv_path, md_path, chart(summary(rows), out / "validate.png")]


def summary(rows: list[dict]) -> dict[str, dict[str, float]]:
    """Per tree: median and slowest wall seconds, median CPU seconds, peak MB, runs."""
    out = {}
    for tree in dict.fromkeys(r["tree"] for r in rows):
        mine = [r for r in rows if r["tree"] == tree]
        out[tree] = {"median": statistics.median(r["seconds"] for r in mine),
                     "slowest": max(r["seconds"] for r in mine),
                     "cpu": statistics.median(r["cpu_seconds"] for r in mine),
                     "peak_mb": max(r["peak_mb"] for r in mine), "runs": len(mine)}
    return out


def markdown(stats: dict[str, dict[str, float]], heavy: dict[str, list[str]]) -> str:
    """The table: one row per tree, against the goal."""
    intro = (f"Each tree validated as `python -m assembly.cli validate TREE` (after one warm-up run); goal: a "
             f"median under {GOAL} s on two cores. Measured on {os.cpu_count()} cores, load average "
             f"{os.getloadavg()[0]:.1f} at the end: on a loaded machine the wall time grows, the CPU time much less.")
    lines = ["# fvtree validate, one process per run", "", intro, "",
             "| tree | runs | median s | slowest s | median CPU s | peak MB | heavy libraries imported |",
             "|---|---|---|---|---|---|---|"]
    for tree, s in stats.items():
        lines.append(f"| {tree} | {s['runs']:.0f} | {s['median']:.3f} | {s['slowest']:.3f} | {s['cpu']:.3f} | "
                     f"{s['peak_mb']:.0f} | {', '.join(heavy[tree]) or 'none'} |")
    return "\n".join([*lines, ""])


def chart(stats: dict[str, dict[str, float]], path: Path) -> Path:
    """Median and slowest seconds per tree, with the goal."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 3.2))
    names = [Path(t).name for t in stats]
    ax.bar(names, [s["slowest"] for s in stats.values()], color="#cccccc", label="slowest")
    ax.bar(names, [s["median"] for s in stats.values()], color="#4477aa", label="median")
    ax.axhline(GOAL, color="#cc3311", linestyle="--", label=f"goal {GOAL} s")
    ax.set_ylabel("s per validation (own process)")
    ax.set_title("fvtree validate: wall time per run")
    ax.legend(loc="upper right", fontsize=8)
    return save(fig, path)
