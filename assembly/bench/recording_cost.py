"""`fvtree bench recording`: what recording a run costs. The simulated assembly (trees/assembly.yaml,
signals mode, supervised as `fvtree run` runs it) with and without its Rerun recording, alternating
so that both see the same machine load, three times each: the real-time factor (median, on wall and
on CPU time), the cost of a tick, and the recording's size per minute of cell time. Writes
recording.csv, recording.md and recording.png. Target: >= 100x real time with recording on.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from assembly.bench import write_csv
from assembly.observe.recorder import RECORDING_FILE
from assembly.run.options import RunOptions
from assembly.run.session import Run

TREE = Path(__file__).resolve().parents[2] / "trees" / "assembly.yaml"
REPEATS = 3
QUICK_SECONDS = 20.0  # --quick: the first seconds of cell time only


def one_run(runs_dir: Path, record: bool, max_time: float = 3600.0) -> dict:
    """One assembly run as `fvtree run` runs it (supervised, with its run directory under `runs_dir`,
    heap frozen), recorded or not: its figures."""
    options = RunOptions(runs_dir=runs_dir, record=record, max_time=max_time, plots=False, quiet=True)
    with Run(TREE, options) as run:
        cpu = time.process_time()
        result = run.loop()
        cpu = time.process_time() - cpu
        summary = run.finish(result)
    size = (Path(str(summary.run_dir)) / RECORDING_FILE).stat().st_size if record else 0
    return {"recording": record, "status": result.status, "ticks": result.ticks,
            "cell_time_s": result.sim_time, "wall_s": result.wall_time, "cpu_s": cpu,
            "rtf_wall": result.sim_time / result.wall_time, "rtf_cpu": result.sim_time / max(cpu, 1e-9),
            "ms_per_tick": 1e3 * result.wall_time / max(result.ticks, 1),
            "bytes": size, "mb_per_cell_minute": size / 1e6 / (result.sim_time / 60.0)}


def run(out: Path, quick: bool = False) -> list[Path]:
    """Alternate runs without and with recording; write the table and the chart."""
    max_time = QUICK_SECONDS if quick else 3600.0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(REPEATS):
            rows.append(one_run(Path(tmp), record=False, max_time=max_time))
            rows.append(one_run(Path(tmp), record=True, max_time=max_time))
    csv_path = write_csv(out / "recording.csv", rows)
    summary = {on: _median(rows, on) for on in (False, True)}
    md_path = out / "recording.md"
    md_path.write_text(_table(summary, rows, quick))
    return [csv_path, md_path, _chart(summary, out / "recording.png")]


def _median(rows: list[dict], recording: bool) -> dict:
    mine = [r for r in rows if r["recording"] == recording]
    return {key: statistics.median(r[key] for r in mine)
            for key in ("rtf_wall", "rtf_cpu", "ms_per_tick", "mb_per_cell_minute", "cell_time_s", "ticks")}


def _table(summary: dict, rows: list[dict], quick: bool) -> str:
    off, on = summary[False], summary[True]
    lines = [(f"# Recording cost ({'quick: first ' + str(QUICK_SECONDS) + ' s of cell time' if quick else 'whole assembly'}"
             f", median of {REPEATS} alternating runs)"), "",
             "| | real-time factor (wall) | real-time factor (CPU) | ms per tick (wall) | MB per minute of cell time |",
             "|---|---|---|---|---|"]
    for name, s in (("without recording", off), ("with recording", on)):
        lines.append(f"| {name} | {s['rtf_wall']:.0f}x | {s['rtf_cpu']:.0f}x | {s['ms_per_tick']:.3f} | "
                     f"{s['mb_per_cell_minute']:.2f} |")
    extra = on["ms_per_tick"] - off["ms_per_tick"]
    lines += ["", (f"Recording adds {extra * 1e3:.0f} us a tick ({100 * extra / off['ms_per_tick']:.0f} %); "
              f"runs: {', '.join(r['status'] for r in rows)}; {on['ticks']:.0f} ticks, {on['cell_time_s']:.1f} s of "
              "cell time each. Target: >= 100x real time with recording on."), ""]
    return "\n".join(lines)


def _chart(summary: dict, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(9, 3.5))
    names = ["without", "with"]
    left.bar(names, [summary[False]["rtf_wall"], summary[True]["rtf_wall"]], color=["#999", "#4682e6"])
    left.axhline(100, color="#d33", ls="--", label="target 100x")
    left.set_ylabel("real-time factor (wall)")
    left.set_title("simulated assembly, recording")
    left.legend()
    right.bar(names, [summary[False]["ms_per_tick"], summary[True]["ms_per_tick"]], color=["#999", "#4682e6"])
    right.set_ylabel("ms per tick (wall)")
    right.set_title(f"{summary[True]['mb_per_cell_minute']:.2f} MB per minute of cell time")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
