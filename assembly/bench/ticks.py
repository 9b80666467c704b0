"""`fvtree bench ticks`: what one tick of the assembly costs, the simulated real-time factor in
both perception modes and the force regret of the placements.

Runs trees/assembly.yaml on the simulated cell with several seeds, as `fvtree run` does (supervised,
recorded, with its run directory, design bridge and transition log, heap frozen), and times every
tick's parts (each pre- and post-tick handler by the runner's name for it: stop policy, perception,
supervisor, recorder, ...; the tree tick; the cell step) and each behaviour's own `update`; then runs
it in pixel mode (each finger's frame rendered and put through the real FingerVision pipeline), the
two fingertips processed in parallel and in one process, alternating. Writes ticks.csv, ticks.md and ticks.png. Targets: tree tick under 0.5 ms median (room for a 500 Hz
robot loop), the whole simulated assembly at least 100x faster than real time in
signals mode and 10x in pixel mode, and force regret under 1 % with 2 % force noise.
"""

from __future__ import annotations

import csv
import os
import statistics
import tempfile
import time
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from assembly.run.loop import Runner
from assembly.run.options import RunOptions
from assembly.run.session import Run

TREE = Path(__file__).resolve().parents[2] / "trees" / "assembly.yaml"
QUICK_PIXEL_SECONDS = 20.0  # --quick: pixel mode over the first seconds of the assembly only


class TickTimes:
    """How long each part of every tick of a runner takes (seconds): each pre- and post-tick handler
    (named as `stage_name` says), the tree tick between them, the cell step and the whole tick, and
    each leaf behaviour's own `update`. Wraps the runner's handlers, leaves and `tick` in place."""

    def __init__(self, runner: Runner):
        self.runner = runner
        self._last_mark = 0.0
        self.parts: dict[str, list[float]] = defaultdict(list)
        self.behaviour_times: dict[str, list[float]] = defaultdict(list)
        for path, node in runner.tree.nodes.items():
            if not node.children:  # leaves: skills and conditions
                node.update = _timed(node.update, self.behaviour_times[path])  # type: ignore[method-assign]
        tree = runner.behaviour_tree
        # Parts in tick order: the marks time the tree tick (between the pre- and post-tick
        # handlers) and the cell step (after the post-tick handlers).
        pre = [_timed(h, self.parts[self.stage_name(h)]) for h in tree.pre_tick_handlers]
        tree_tick = self.parts["tree tick"]
        post = [_timed(h, self.parts[self.stage_name(h)]) for h in tree.post_tick_handlers]
        self._cell_step, self._whole_tick = self.parts["cell step"], self.parts["whole tick"]
        tree.pre_tick_handlers[:] = [*pre, self._mark]
        tree.post_tick_handlers[:] = [lambda _: tree_tick.append(time.perf_counter() - self._last_mark),
                                      *post, self._mark]
        self._tick = runner.tick
        runner.tick = self._timed_tick  # type: ignore[method-assign]  # the loop calls the instance's tick

    def stage_name(self, handler) -> str:
        """A tick handler's stage: the runner's attribute holding it or the object it is a method
        of ("recorder", "stop policy"), its own name for a method of the runner ("kick watchdog"),
        else its class; unique (a second handler of one name gets " 2")."""
        owner = getattr(handler, "__self__", None)
        if owner is self.runner:
            name = handler.__name__
        else:
            name = next((attr for attr, value in vars(self.runner).items()
                         if value is handler or (owner is not None and value is owner)), type(handler).__name__)
        name = name.strip("_").replace("_", " ")
        n = 1
        while (f"{name} {n}" if n > 1 else name) in self.parts:
            n += 1
        return f"{name} {n}" if n > 1 else name

    def _mark(self, tree) -> None:
        self._last_mark = time.perf_counter()

    def _timed_tick(self):
        start = time.perf_counter()
        status = self._tick()
        end = time.perf_counter()
        self._cell_step.append(end - self._last_mark)
        self._whole_tick.append(end - start)
        return status


def _timed(function, sink: list[float]):
    """`function`, appending the seconds each call takes to `sink`."""
    clock = time.perf_counter

    def timed(*args):
        t0 = clock()
        result = function(*args)
        sink.append(clock() - t0)
        return result
    return timed


def _one_run(timed: bool, seed: int = 0, cell_file: str = "sim"):
    """One full assembly on a fresh tree and design (a run marks the design's elements placed)."""
    doc, times, result, cell, _ = _assembly(timed, seed, cell_file)
    if result.status != "SUCCESS":
        raise RuntimeError(f"benchmark run ended {result.status}: {result.message}")
    truth = cell.world.truth()
    regrets = [truth[e]["regret"] for e in doc.design.build_order()]
    return doc, times, result, regrets


def _assembly(timed: bool, seed: int, cell_file: str = "sim", perception: str | None = None,
              max_time: float = 3600.0):
    """(document, tick times or None, result, cell, CPU seconds of the run) of one assembly run as
    `fvtree run` runs it (supervised, recorded with camera frames at the default rate, a run
    directory with its design bridge and transition log, heap frozen; no progress line); on a shared
    machine other processes add wall time but not CPU time. The CPU time includes the pixel-mode
    worker processes'."""
    with tempfile.TemporaryDirectory() as tmp:
        options = RunOptions(cell=cell_file, seed=seed, perception=perception, max_time=max_time,
                             runs_dir=Path(tmp), plots=False, quiet=True)
        with Run(TREE, options) as run:
            times = TickTimes(run.runner) if timed else None
            cpu = time.process_time()
            result = run.loop()
            cpu = time.process_time() - cpu + _workers_cpu(run.cell)
            run.finish(result)  # the event log's end goes in and the recording's file is complete
    return run.doc, times, result, run.cell, cpu


def _workers_cpu(cell) -> float:
    """CPU seconds the cell's perception worker processes have used (pixel mode's fingers in
    parallel; 0 without workers), read before the cell closes them."""
    total = 0.0
    for process in getattr(cell.sense, "processes", {}).values():
        try:
            fields = Path(f"/proc/{process.pid}/stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime
    return total


PIXEL_SETUPS = {"fingers in parallel": {}, "one process": {"pixel_workers": False}}


def _pixel_runs(out_dir: Path, repeats: int, quick: bool) -> dict[str, list[tuple]]:
    """Setup -> (result, real-time factor on CPU time) of untimed pixel-mode runs (seeds
    0..repeats-1), the fingertips processed in parallel and in one process, alternating so that both
    see the same machine load; with `quick`, the first seconds only."""
    limit = QUICK_PIXEL_SECONDS if quick else 3600.0
    cells = {name: _cell_variant(out_dir, name.replace(" ", "_"), changes) for name, changes in PIXEL_SETUPS.items()}
    runs: dict[str, list[tuple]] = {name: [] for name in PIXEL_SETUPS}
    for seed in range(repeats):
        for name, cell_file in cells.items():
            _, _, result, _, cpu = _assembly(False, seed, cell_file, perception="pixels", max_time=limit)
            runs[name].append((result, result.sim_time / max(cpu, 1e-9)))
    return runs


def _cell_variant(out_dir: Path, name: str, changes: dict) -> str:
    """A copy of the simulated cell file with top-level keys changed (`world` merged)."""
    import yaml

    from drivers.cell_file import resolve_cell_path

    data = yaml.safe_load(resolve_cell_path("sim").read_text())
    for key, value in changes.items():
        data[key] = {**data[key], **value} if key == "world" else value
    path = out_dir / f"sim_{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@dataclass
class Measured:
    """What `run` measured: the untimed signals-mode runs' real-time factors and regrets (by force
    noise), the timed run's tick times, and the pixel-mode runs (setup -> (result, RTF on CPU time))."""

    repeats: int
    quick: bool
    factors: list[float]
    regrets: dict[float, list[float]]
    times: TickTimes
    ticks: int
    tick_hz: float
    pixel_runs: dict[str, list[tuple]]

    @property
    def tree_median_ms(self) -> float:
        return statistics.median(self.times.parts["tree tick"]) * 1e3

    @property
    def pixel_factors(self) -> dict[str, list[float]]:
        return {name: [r.real_time_factor for r, _ in runs] for name, runs in self.pixel_runs.items()}


def run(out_dir: Path, quick: bool = False) -> list[Path]:
    """Measure; write ticks.csv, ticks.md and ticks.png."""
    out_dir.mkdir(parents=True, exist_ok=True)
    measured = _measure(out_dir, quick)
    rows = _rows(measured)
    md = _markdown(measured, rows)
    print("\n".join(md[2:9]))
    return [_write_csv(rows, out_dir / "ticks.csv"), _write_text("\n".join(md), out_dir / "ticks.md"),
            _chart(measured, rows, out_dir / "ticks.png")]


def _measure(out_dir: Path, quick: bool) -> Measured:
    repeats = 1 if quick else 5
    factors: list[float] = []
    regrets: dict[float, list[float]] = {0.02: [], 0.05: []}
    noisy = _cell_variant(out_dir, "noise_0.05", {"world": {"force_noise": 0.05}})
    for seed in range(repeats):  # untimed runs: real-time factor without instrumentation overhead
        _, _, result, regret = _one_run(timed=False, seed=seed)
        factors.append(result.real_time_factor)
        regrets[0.02] += regret
        regrets[0.05] += _one_run(False, seed, noisy)[3]
    doc, times, result, _ = _one_run(timed=True)
    return Measured(repeats, quick, factors, regrets, times, result.ticks, doc.tick_hz,
                    _pixel_runs(out_dir, 1 if quick else 3, quick))


def _rows(m: Measured) -> list[tuple]:
    """(group, name, count, median, p95, max, mean) rows of every figure."""
    us = 1e6
    rows = [_row("stage µs", name, values, us) for name, values in m.times.parts.items()]
    called = {p: v for p, v in m.times.behaviour_times.items() if v}
    rows += [_row("behaviour µs", path.split("/")[-1], values, us)
             for path, values in sorted(called.items(), key=lambda kv: -np.median(kv[1]))]
    rows += [_row("regret %", f"force noise {noise:.0%}", values, 100) for noise, values in m.regrets.items()]
    rows.append(_row("real-time factor", "signals mode", m.factors, 1))
    for name, runs in m.pixel_runs.items():
        rows += [_row("real-time factor", f"pixels mode, {name}", m.pixel_factors[name], 1),
                 _row("real-time factor", f"pixels mode, {name}, on CPU time", [cpu for _, cpu in runs], 1)]
    return rows


def _write_csv(rows: list[tuple], path: Path) -> Path:
    units = {"regret %": "%", "real-time factor": "x"}
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["group", "name", "count", "median", "p95", "max", "mean", "unit"])
        w.writerows((g, n, c, f"{m:.4g}", f"{p:.4g}", f"{x:.4g}", f"{a:.4g}", units.get(g, "us"))
                    for g, n, c, m, p, x, a in rows)
    return path


def _write_text(text: str, path: Path) -> Path:
    path.write_text(text)
    return path


def _markdown(m: Measured, rows: list[tuple]) -> list[str]:
    low, high = m.regrets[0.02], m.regrets[0.05]
    return [
        "# Tick cost of trees/assembly.yaml on the simulated cell",
        "",
        f"- tree tick median: **{m.tree_median_ms:.3f} ms** (target < 0.5 ms)",
        (f"- simulated assembly real-time factor, median of {m.repeats} runs: **{statistics.median(m.factors):.0f}x** "
         f"(target >= 100x; runs: {', '.join(f'{x:.0f}' for x in m.factors)})"),
        *_pixel_lines(m.pixel_runs, m.quick),
        (f"- force regret with 2 % force noise, {len(low)} placements (seeds 0-{m.repeats - 1}): "
         f"median **{np.median(low) * 100:.3f} %**, max {np.max(low) * 100:.3f} % "
         f"(target < 1 %); with 5 % noise: max {np.max(high) * 100:.3f} %"),
        f"- ticks per run: {m.ticks} at {m.tick_hz:g} Hz",
        _recorder_line(m.times.parts, m.tick_hz),
        "",
        "| group | name | count | median | p95 | max | mean |",
        "|---|---|---:|---:|---:|---:|---:|",
        *[f"| {g} | {n} | {c} | {md:.4g} | {p:.4g} | {x:.4g} | {a:.4g} |" for g, n, c, md, p, x, a in rows],
        "",
    ]


def _chart(m: Measured, rows: list[tuple], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.5))
    stage = [r for r in rows if r[0] == "stage µs" and r[1] != "whole tick"]
    left.bar([r[1] for r in stage], [r[3] for r in stage], color="C0", label="median")
    left.bar([r[1] for r in stage], [r[4] - r[3] for r in stage], bottom=[r[3] for r in stage],
             color="C0", alpha=0.3, label="to p95")
    left.set_ylabel("µs per tick")
    left.tick_params(axis="x", labelrotation=30)
    left.set_title(f"tick parts (tree tick median {m.tree_median_ms * 1000:.0f} µs; RTF "
                   f"{statistics.median(m.factors):.0f}x, pixel mode "
                   f"{statistics.median(m.pixel_factors['fingers in parallel']):.1f}x)")
    left.legend()
    beh = [r for r in rows if r[0] == "behaviour µs"]
    right.barh([r[1] for r in beh][::-1], [r[3] for r in beh][::-1], color="C1")
    right.set_xlabel("median µs per update")
    right.set_title("per behaviour (own update only)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _pixel_lines(pixel_runs: dict[str, list[tuple]], quick: bool) -> list[str]:
    """One line per pixel-mode setup: median real-time factor on wall and CPU time, and the runs."""
    lines = []
    for name, runs in pixel_runs.items():
        wall = [r.real_time_factor for r, _ in runs]
        what = (f"the first {QUICK_PIXEL_SECONDS:g} s of sim time" if quick
                else ", ".join(f"{r.status} in {r.sim_time:.0f} s" for r, _ in runs))
        lines.append(f"- pixel-mode assembly (two rendered sensors through the real pipeline), {name}, median of "
                     f"{len(runs)} runs alternating with the other set-up: **{statistics.median(wall):.1f}x** real "
                     f"time (target >= 10x; runs: {', '.join(f'{x:.1f}' for x in wall)}; {what}); on CPU time, "
                     f"workers included, {statistics.median(cpu for _, cpu in runs):.1f}x")
    return lines


def _row(group: str, name: str, values: list[float], scale: float) -> tuple:
    """(group, name, count, median, p95, max, mean) of `values` times `scale`."""
    v = np.array(values) * scale
    return group, name, len(v), float(np.median(v)), float(np.percentile(v, 95)), float(v.max()), float(v.mean())


def _recorder_line(parts: dict[str, list[float]], tick_hz: float) -> str:
    """What recording costs a tick (its mean: it sends its columns in batches of ticks) against the
    whole tick and the budget of a tick at 100x real time."""
    whole = 1e6 * float(np.mean(parts["whole tick"]))
    budget = f"100x real time at {tick_hz:g} Hz needs <= {1e6 / (100 * tick_hz):.0f} µs a tick"
    if "recorder" not in parts:
        return f"- whole tick: mean {whole:.0f} µs, not recorded; {budget}"
    rec = 1e6 * np.array(parts["recorder"])
    return (f"- recorder: mean **{rec.mean():.1f} µs a tick** (median {np.median(rec):.1f} µs, max {rec.max():.0f} µs: "
            f"it sends its columns once per batch of ticks) of a whole tick of mean {whole:.0f} µs "
            f"({100 * rec.mean() / whole:.0f} %); {budget}")
