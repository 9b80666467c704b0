"""`fvtree bench ticks`: what one tick of the assembly costs, the simulated real-time factor in
both perception modes and the force regret of the placements.

Runs trees/assembly.yaml on the simulated cell with several seeds, as `fvtree run` does (supervised,
recorded, with its run directory, design bridge and transition log, heap frozen), and times every
tick's parts (each pre- and post-tick handler by the runner's name for it: stop policy, perception,
supervisor, recorder, ...; the tree tick; the cell step) and each behaviour's own `update`; then runs
it in pixel mode (each finger's frame rendered and put through the real FingerVision pipeline), the
two fingertips processed in parallel and in one process, alternating. Writes ticks.csv, ticks.md and
ticks.png. Targets: tree tick under 0.5 ms median (room for a 500 Hz robot loop), the whole simulated
assembly at least 100x faster than real time in signals mode and 10x in pixel mode, and force regret
under 1 % with 2 % force noise.

Two more parts (`--parts`; all three by default) go beside it in ticks.md:
- `options` (`assembly.bench.speed_accuracy`): both modes' real-time factor beside the assembly's
  success rate and median regret over randomised seeds (`--seeds`, default 3), once per simulation
  option (each physics model on and off); ticks_options.csv and the chart ticks_options.png (CPU time
  per tick against regret).
- `costs` (`assembly.bench.tick_costs`): each newer check's and model's cost a tick in µs, measured
  side by side with it off; ticks_costs.csv.
"""

from __future__ import annotations

import csv
import statistics
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from assembly.bench import speed_accuracy, tick_costs
from assembly.bench.tick_timing import TickTimes, assembly_run

QUICK_PIXEL_SECONDS = 20.0  # --quick: pixel mode over the first seconds of the assembly only


def _one_run(timed: bool, seed: int = 0, cell_file: str = "sim"):
    """One full assembly on a fresh tree and design (a run marks the design's elements placed)."""
    done = assembly_run(timed, seed, cell_file)
    doc, times, result, cell = done.doc, done.times, done.result, done.cell
    if result.status != "SUCCESS":
        raise RuntimeError(f"benchmark run ended {result.status}: {result.message}")
    assert cell.world is not None and doc.design is not None  # the sim cell's assembly scene, the tree's design
    truth = cell.world.truth()
    regrets = [truth[e]["regret"] for e in doc.design.build_order()]
    return doc, times, result, regrets


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
            done = assembly_run(False, seed, cell_file, perception="pixels", max_time=limit)
            runs[name].append((done.result, done.cpu_factor))
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


PARTS = ("ticks", "options", "costs")
QUICK_OPTION_SECONDS = 10.0  # --quick: each option's runs over the first seconds only (nothing placed: no regret)


def run(out_dir: Path, quick: bool = False, parts: Sequence[str] = PARTS, seeds: int | None = None) -> list[Path]:
    """Measure the chosen `parts`; write ticks.md and each part's table and chart."""
    out_dir.mkdir(parents=True, exist_ok=True)
    md = ["# Tick cost of trees/assembly.yaml on the simulated cell", "", f"Code: {_revision()}.", ""]
    written: list[Path] = []
    if "ticks" in parts:
        measured = _measure(out_dir, quick)
        rows = _rows(measured)
        lines = _markdown(measured, rows)
        print("\n".join(lines[:7]))
        md += lines
        written += [_write_csv(rows, out_dir / "ticks.csv"), _chart(measured, rows, out_dir / "ticks.png")]
    if "options" in parts:
        count = seeds or (1 if quick else speed_accuracy.SEEDS)
        runs = speed_accuracy.measure(out_dir, count, max_time=QUICK_OPTION_SECONDS if quick else 3600.0)
        print("\n".join(speed_accuracy.headline(runs, count)))
        md += speed_accuracy.markdown(runs, count)
        written += [speed_accuracy.write_table(runs, out_dir / "ticks_options.csv"),
                    speed_accuracy.chart(runs, out_dir / "ticks_options.png")]
    if "costs" in parts:
        repeats, pixels_time = (1, 3.0) if quick else (3, QUICK_PIXEL_SECONDS)
        costs = tick_costs.rows(tick_costs.measure(out_dir, repeats, QUICK_OPTION_SECONDS if quick else 3600.0,
                                                   pixels_time))
        md += tick_costs.markdown(costs, repeats, pixels_time)
        written.append(tick_costs.write_table(costs, out_dir / "ticks_costs.csv"))
    return [*written, _write_text("\n".join(md), out_dir / "ticks.md")]


def _revision() -> str:
    """The git commit the measured code is at (with `+ changes` when the work tree differs), or
    'not a git checkout'."""
    import subprocess

    where = Path(__file__).resolve().parent
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=where, capture_output=True, text=True,
                                check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=where,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "not a git checkout"
    return f"commit {commit}" + (" + uncommitted changes" if dirty else "")


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
        "## Tick parts, real-time factor and regret on the sim cell",
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
