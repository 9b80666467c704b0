"""Speed against accuracy: the assembly (trees/assembly.yaml) over randomised seeds, in both perception
modes, once per simulation option (`assembly.bench.sim_options`: every physics model on, each one
off, all off, the camera look drawn), so that a faster path that loses accuracy shows at once.

Every run is `fvtree run` on the randomised cell (`world: {randomise: true}`, as `fvtree bench
robustness` runs it: each seed draws its own sensor, skin, force sensor and scene) with recording on,
in this process; the options alternate within each seed so that they see the same machine load. A
run is judged as the robustness bench judges it (`assembly.bench.robustness.row_of`: the verdict
against the scene's truth, the force regret of each placed element, SUCCESS with the task undone
counted dishonest). Its speed is taken on CPU time (the pixel-mode worker processes' included),
which other jobs on a shared machine do not inflate, and on wall time.
"""

from __future__ import annotations

import statistics
from collections.abc import Sequence
from pathlib import Path

from assembly.bench import write_csv
from assembly.bench.demos import MODES, save
from assembly.bench.robustness import row_of, table
from assembly.bench.sim_options import OPTIONS, SimOption, option_cell, pinned
from assembly.bench.tick_timing import TREE, assembly_run

SEEDS = 3  # per option and mode (`--seeds`); `fvtree bench robustness --trees assembly` runs 20
WARM_UP_SECONDS = 2.0  # of cell time, per mode, before the measured runs


def measure(out_dir: Path, seeds: int = SEEDS, options: Sequence[SimOption] = OPTIONS,
            modes: Sequence[str] = MODES, max_time: float = 3600.0) -> list[dict]:
    """One row per run: the robustness bench's row of it plus the option, ticks, simulated
    seconds, CPU µs per tick and the real-time factors on wall and CPU time. `max_time` below the
    assembly's length stops the runs early (TIMEOUT: speed without accuracy)."""
    cells = {o.name: option_cell(out_dir, o, randomised=True) for o in options}
    rows = []
    for mode in modes:  # a short run first: the first run in a process pays for its imports and caches
        assembly_run(False, 0, str(cells[options[0].name]), perception=mode, max_time=WARM_UP_SECONDS)
    for mode in modes:
        for seed in range(seeds):
            for chosen in options:
                if mode not in chosen.modes:
                    continue
                with pinned(chosen):
                    done = assembly_run(False, seed, str(cells[chosen.name]), perception=mode, max_time=max_time)
                result = done.result
                row = row_of(TREE, mode, seed, done.summary.to_json())
                row.update(option=chosen.name, ticks=result.ticks, sim_time_s=round(result.sim_time, 3),
                           cpu_us_per_tick=1e6 * done.cpu_per_tick, rtf_wall=result.real_time_factor,
                           rtf_cpu=done.cpu_factor)
                rows.append(row)
    for path in cells.values():
        path.unlink()
    return rows


def summary(rows: list[dict]) -> list[dict]:
    """Per (option, mode): the robustness bench's figures (runs, successes, success rate, dishonest,
    median regret and placement error) beside the median CPU µs per tick and real-time factors."""
    out = []
    for option, mode in dict.fromkeys((r["option"], r["mode"]) for r in rows):
        runs = [r for r in rows if r["option"] == option and r["mode"] == mode]
        judged = table(runs)[0]
        regret = [x for r in runs for x in r["regret_pct"]]
        out.append({"option": option, "mode": mode, "runs": judged["runs"], "successes": judged["successes"],
                    "success_rate": judged["success_rate"], "dishonest": judged["dishonest"],
                    "median_regret_pct": statistics.median(regret) if regret else None,
                    "worst_regret_pct": max(regret) if regret else None,
                    "median_placement_error_mm": judged.get("median_placement_error_mm"),
                    "cpu_us_per_tick": statistics.median(r["cpu_us_per_tick"] for r in runs),
                    "rtf_cpu": statistics.median(r["rtf_cpu"] for r in runs),
                    "rtf_wall": statistics.median(r["rtf_wall"] for r in runs),
                    "ticks": statistics.median(r["ticks"] for r in runs)})
    return out


COLUMNS = ["option", "mode", "runs", "successes", "success_rate", "dishonest", "median_regret_pct",
           "worst_regret_pct", "median_placement_error_mm", "cpu_us_per_tick", "rtf_cpu", "rtf_wall", "ticks"]


def write_table(rows: list[dict], path: Path) -> Path:
    """The summary as CSV (numbers to 4 significant digits; empty: not measured)."""
    def cell(value):
        return "" if value is None else f"{value:.4g}" if isinstance(value, float) else value
    return write_csv(path, [{k: cell(v) for k, v in s.items()} for s in summary(rows)], COLUMNS)


def _num(value: float | None, digits: str = ".3g") -> str:
    return "—" if value is None else format(value, digits)


def headline(rows: list[dict], seeds: int) -> list[str]:
    """Both modes' real-time factor beside the assembly's robustness, every model on."""
    lines = []
    for s in summary(rows):
        if s["option"] != OPTIONS[0].name:
            continue
        lines.append(f"- {s['mode']} mode, every model on, seeds 0-{seeds - 1} of the randomised cell: "
                     f"**{s['rtf_wall']:.1f}x** real time (wall; {s['rtf_cpu']:.1f}x on CPU time), "
                     f"{s['cpu_us_per_tick']:.0f} µs CPU a tick; verdict SUCCESS in **{s['successes']}/{s['runs']}**, "
                     f"median force regret **{_num(s['median_regret_pct'])} %** (worst {_num(s['worst_regret_pct'])} %), "
                     f"{s['dishonest']} dishonest")
    return lines


def markdown(rows: list[dict], seeds: int) -> list[str]:
    """The section of ticks.md: what was run, the headline, the table and the runs that failed."""
    lines = ["## Speed against accuracy, per simulation option", "",
             (f"trees/assembly.yaml run as `fvtree run --perception MODE --seed N` (recorded) on the randomised "
              f"sim cell, seeds 0-{seeds - 1} per option and mode, in this benchmark's process (the figures of "
              "`fvtree bench robustness --trees assembly` for the same seeds, measured here on this code, not "
              "read from an earlier robustness.json). Success: the verdict against the scene's truth; regret: "
              "each placed element's force regret (%); time per tick: CPU µs (pixel-mode workers included); "
              "real-time factor: simulated over wall seconds, and over CPU seconds."), "",
             *headline(rows, seeds), "",
             ("| option | mode | success | dishonest | median regret (%) | worst regret (%) | median placement "
             "error (mm) | CPU µs per tick | RTF (CPU) | RTF (wall) | ticks |"),
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for s in summary(rows):
        lines.append(f"| {s['option']} | {s['mode']} | {s['successes']}/{s['runs']} | {s['dishonest']} | "
                     f"{_num(s['median_regret_pct'])} | {_num(s['worst_regret_pct'])} | "
                     f"{_num(s['median_placement_error_mm'])} | {s['cpu_us_per_tick']:.0f} | {s['rtf_cpu']:.1f} | "
                     f"{s['rtf_wall']:.1f} | {s['ticks']:.0f} |")
    failed = [r for r in rows if r["status"] != "SUCCESS" or r.get("dishonest")]
    lines += ["", "Options' runs that failed or lied:" if failed else "Every option's runs succeeded honestly.", ""]
    lines += [f"- {r['option']}, {r['mode']}, seed {r['seed']}: {r['status']} "
              f"{r.get('why') or 'DISHONEST: ' + str(r.get('dishonest'))}".rstrip() for r in failed]
    from assembly.bench.sim_options import __doc__ as about

    lines += ["", "Options: " + "; ".join(f"**{o.name}**: {o.about}" for o in OPTIONS) + ". "
              + (about or "").split("\n\n")[-1].replace("\n", " ").strip(), ""]
    return lines


def chart(rows: list[dict], path: Path) -> Path:
    """CPU time per tick against median force regret, one point per option and mode (the success
    count beside it); an option whose runs placed nothing is drawn on the bottom axis, hollow."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 5.5))
    marks = {"signals": "o", "pixels": "s"}
    for i, chosen in enumerate(OPTIONS):
        for s in (s for s in summary(rows) if s["option"] == chosen.name):
            regret = s["median_regret_pct"]
            y = 0.0 if regret is None else regret
            ax.scatter(s["cpu_us_per_tick"], y, s=60, marker=marks.get(s["mode"], "^"),
                       facecolors="none" if regret is None else f"C{i}", edgecolors=f"C{i}",
                       label=chosen.name if s["mode"] == "signals" or chosen.modes == ("pixels",) else None)
            ax.annotate(f"{s['successes']}/{s['runs']}", (s["cpu_us_per_tick"], y), textcoords="offset points",
                        xytext=(6, 4), fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel("CPU µs per tick (log; circles: signals mode, squares: pixel mode)")
    ax.set_ylabel("median force regret (%)")
    ax.set_title("assembly on the randomised cell: time per tick against regret (success count beside)")
    ax.legend(fontsize=7, loc="best")
    ax.grid(alpha=0.3)
    return save(fig, path)
