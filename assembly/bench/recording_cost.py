"""`fvtree bench recording`: what recording a run costs. The simulated assembly (trees/assembly.yaml,
signals mode, supervised as `fvtree run` runs it) with and without its Rerun recording, alternating
so that both see the same machine load, three times each: the real-time factor (median, on wall and
on CPU time), the cost of a tick, and the recording's size per minute of cell time. Writes
recording.csv, recording.md and recording.png. Target: >= 100x real time with recording on.
"""

from __future__ import annotations

import csv
import gc
import statistics
import tempfile
import time
from pathlib import Path

from assembly.language.build import build
from assembly.language.reader import load_tree
from assembly.observe.recorder import RunRecorder
from assembly.run.loop import Runner
from assembly.run.perception_stage import clear_blackboard
from assembly.run.supervisor import Supervision
from drivers.cell_builders import load_cell

TREE = Path(__file__).resolve().parents[2] / "trees" / "assembly.yaml"
REPEATS = 3
QUICK_SECONDS = 20.0  # --quick: the first seconds of cell time only


def one_run(record_to: Path | None, max_time: float = 3600.0) -> dict:
    """One supervised assembly as `fvtree run` ticks it (heap frozen), recorded to `record_to` (None:
    not recorded): its figures."""
    doc = load_tree(TREE)
    clear_blackboard()
    cell = load_cell("sim", doc.tick_hz, doc.scene, doc.design.scene_args(), seed=0)
    built = build(doc)
    recorder = RunRecorder(built, cell, record_to, design=doc.design) if record_to else None
    runner = Runner(built, cell, supervision=Supervision.of_cell("sim"), max_time=max_time, recorder=recorder)
    runner.setup()
    gc.collect()  # as `fvtree run` does (session._frozen_heap): no full collections over the heap so far
    gc.freeze()
    cpu = time.process_time()
    try:
        result = runner.run()
    finally:
        cpu = time.process_time() - cpu
        gc.unfreeze()
        cell.close()
    if recorder is not None:
        recorder.event("end", status=result.status, where=result.where, message=result.message)
        recorder.finish()
    size = record_to.stat().st_size if record_to else 0
    return {"recording": record_to is not None, "status": result.status, "ticks": result.ticks,
            "cell_time_s": result.sim_time, "wall_s": result.wall_time, "cpu_s": cpu,
            "rtf_wall": result.sim_time / result.wall_time, "rtf_cpu": result.sim_time / max(cpu, 1e-9),
            "ms_per_tick": 1e3 * result.wall_time / max(result.ticks, 1),
            "bytes": size, "mb_per_cell_minute": size / 1e6 / (result.sim_time / 60.0)}


def run(out: Path, quick: bool = False) -> list[Path]:
    """Alternate runs without and with recording; write the table and the chart."""
    max_time = QUICK_SECONDS if quick else 3600.0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(REPEATS):
            rows.append(one_run(None, max_time))
            rows.append(one_run(Path(tmp) / f"run{i}.rrd", max_time))
    csv_path = out / "recording.csv"
    with open(csv_path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
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
