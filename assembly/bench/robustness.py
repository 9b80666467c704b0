"""`fvtree bench robustness`: every demo tree (the list `fvtree bench demos` runs) over many seeds of
the randomised simulated cell (`world: {randomise: true}`: sensor gains, rest jitter, skin lag and
creep, force-sensor offset, drift and noise, object mass and size, plate stiffness and supports,
the person's pull; ranges in drivers/sim/scenes/randomise.py and `fvtree scenes`), in both perception
modes. Writes robustness.json (every run), robustness.md (success rate, the key metric's median and
spread per tree and mode, the assembly's regret and placement error, every failure with its status
and cause) and robustness.png.

A run counts as a success when its verdict (the tree's status checked against the scene's truth) is
SUCCESS. A run is flagged DISHONEST when it says SUCCESS while its key metric is outside the limit
of the task (the scene verdict's tolerance where the scene has one, else the bench's own limit
below): that is a task undone and called done, the one thing a robust skill must never do.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from assembly.bench.demos import MODES, demo_trees, save
from drivers.cell_file import CELLS_DIR
from drivers.sim.scenes import randomise
from fvfiles.yaml_source import load_file

SEEDS = 20
QUICK_SEEDS, QUICK_TREES, QUICK_MODES = 1, ("hold.yaml",), ("signals",)  # --quick: one honest run
GOAL = 0.95  # share of seeds each demo should succeed in (issue 26)


@dataclass(frozen=True)
class Key:
    """A demo's key metric: its `name` and unit, how to read it from a run's summary (None: not
    measured), and the limit beyond which the task is undone: the scene tolerance `tolerance` when
    the run's verdict has it, else `limit` (None: no limit; the verdict alone judges)."""

    name: str
    read: Callable[[dict, Path], float | None]
    tolerance: str = ""
    limit: float | None = None
    scale: float = 1.0  # the tolerance in the metric's unit


def _metric(label: str) -> Callable[[dict, Path], float | None]:
    def read(summary: dict, tree: Path) -> float | None:
        value = summary.get("metrics", {}).get(label)
        return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None
    return read


def _target(tree: Path, skill: str) -> float | None:
    """The `target` param of the first `skill` node of a tree file."""
    def walk(node: Any) -> float | None:
        if isinstance(node, dict):
            if node.get("skill") == skill and isinstance(node.get("params"), dict) and "target" in node["params"]:
                return float(node["params"]["target"])
            return next((v for v in map(walk, node.values()) if v is not None), None)
        if isinstance(node, list):
            return next((v for v in map(walk, node) if v is not None), None)
        return None
    return walk(load_file(tree))


def _off_target(label: str, skill: str) -> Callable[[dict, Path], float | None]:
    """|metric - the tree's target for `skill`|."""
    def read(summary: dict, tree: Path) -> float | None:
        value, target = _metric(label)(summary, tree), _target(tree, skill)
        return None if value is None or target is None else abs(value - target)
    return read


def _worst_regret(summary: dict, tree: Path) -> float | None:
    regrets = [e["regret"] for e in summary.get("elements", {}).values() if e.get("regret") is not None]
    return 100.0 * max(regrets) if regrets else None


def placement_errors(summary: dict) -> list[float]:
    """|placed - true maximum-load position| per placed element (mm)."""
    return [1000.0 * abs(e["position"] - e["true_best_position"]) for e in summary.get("elements", {}).values()
            if e.get("position") is not None and e.get("true_best_position") is not None]


def regrets(summary: dict) -> list[float]:
    """The force regret of each placed element (%)."""
    return [100.0 * e["regret"] for e in summary.get("elements", {}).values() if e.get("regret") is not None]


def _taken_back(summary: dict, tree: Path) -> float | None:
    """1 when the person took the bottle back, 0 when not (dropped, still held)."""
    bottle = summary.get("metrics", {}).get("bottle")
    return None if bottle is None else float(bottle == "taken back by the person")


def _bowls_right(summary: dict, tree: Path) -> float | None:
    """Share of the tree's bowls classified as expected (its `as_expected` checks that passed)."""
    log = Path(summary.get("run_dir") or "") / "transitions.jsonl"
    if not log.exists():
        return None
    passed = {row["node"] for row in map(json.loads, log.read_text().splitlines())
              if row["node"].endswith("/as_expected") and row["to"] == "SUCCESS"}
    bowls = sum(1 for line in tree.read_text().splitlines() if "subtree: classify_bowl" in line)
    return len(passed) / bowls if bowls else None


KEYS: dict[str, Key] = {
    "assembly.yaml": Key("worst regret (%)", _worst_regret, "max_regret", scale=100.0),
    "assembly_heavy.yaml": Key("worst regret (%)", _worst_regret, "max_regret", scale=100.0),
    "force_track.yaml": Key("tracking error rms (mm)", _metric("tracking error rms (mm)")),
    "object_track.yaml": Key("tracking error rms (mm)", _metric("tracking error rms (mm)")),
    "in_hand_rot.yaml": Key("angle off target (deg)", _off_target("turned in the hand (deg)", "in_hand_rot"), limit=15.0),
    "in_hand_man.yaml": Key("angle off target (deg)", _off_target("turned in the hand (deg)", "in_hand_man"), limit=10.0),
    "arm_rot.yaml": Key("stick from hanging (deg)", _metric("stick from hanging (deg)"), limit=10.0),
    "press_with_force.yaml": Key("force error (N)", _off_target("force on the scale (N)", "press_with_force"),
                                 limit=1.0),
    "press_release.yaml": Key("stick slid in the grip (mm)", _metric("stick slid in the grip (mm)")),
    "hold.yaml": Key("box slid (mm)", _metric("box slid (mm)"), limit=20.0),
    "handover.yaml": Key("bottle taken back (1: yes)", _taken_back),
    "classify_substance.yaml": Key("bowls classified right (share)", _bowls_right),
}
# The tracking demos' undone-task check is the scene's own: the final error against max_final_error_mm.
FINAL_ERROR = Key("tracking error final (mm)", _metric("tracking error final (mm)"), "max_final_error_mm")


def randomised_cell(where: Path) -> Path:
    """A copy of the sim cell file with `world: {randomise: true}`."""
    text = (CELLS_DIR / "sim.yaml").read_text()
    marked = text.replace("\nworld:\n", f"\nworld:\n  {randomise.RANDOMISE}: true\n", 1)
    if marked == text:
        raise RuntimeError("drivers/cells/sim.yaml has no `world:` section: update this bench")
    path = where / "sim_randomised.yaml"
    path.write_text(marked)
    return path


def undone(key: Key, summary: dict, tree: Path) -> str:
    """Why a run that says SUCCESS did not do its task ('' when it did, or nothing says otherwise)."""
    tolerances = (summary.get("truth") or {}).get("tolerances") or {}
    checks = [key, FINAL_ERROR] if tree.name in ("force_track.yaml", "object_track.yaml") else [key]
    for check in checks:
        value = check.read(summary, tree)
        limit = tolerances[check.tolerance] * check.scale if check.tolerance in tolerances else check.limit
        if value is not None and limit is not None and value > limit:
            return f"{check.name} {value:.3g} > {limit:g}"
    placed = [e for e in summary.get("elements", {}).values() if e.get("status") == "placed"]
    if summary.get("elements") and len(placed) < len(summary["elements"]):
        return f"{len(placed)} of {len(summary['elements'])} elements placed"
    return ""


def row_of(tree: Path, mode: str, seed: int, summary: dict) -> dict:
    """One randomised run's row: its verdict, key metric, the draws that matter most, why it failed
    and whether it lied."""
    key = KEYS.get(tree.name, Key("none", lambda s, t: None))
    status = str(summary.get("status"))
    drawn = {**randomise.draw("sensor", seed), **randomise.draw("force_sensor", seed)}
    row: dict[str, Any] = {"tree": tree.name, "mode": mode, "seed": seed, "status": status,
           "metric": key.name, "value": key.read(summary, tree), "skin_lag_s": round(drawn["skin_lag_s"], 3),
           "force_offset_N": round(drawn["offset"], 2), "rest_jitter_px": round(drawn["rest_jitter_px"], 3),
           "gain": round(drawn["gain"], 3), "regret_pct": regrets(summary),
           "placement_error_mm": placement_errors(summary)}
    if status != "SUCCESS":
        shortfalls = (summary.get("truth") or {}).get("shortfalls") or []
        why = " ".join(str(summary.get(k) or "") for k in ("where", "message")).strip()
        row["why"] = why + "".join(f"; not done: {s}" for s in shortfalls)
    else:
        row["dishonest"] = undone(key, summary, tree)
    return row


def run_seeds(tree: Path, mode: str, seeds: list[int], cell: Path, tmp: Path) -> list[dict]:
    """The rows of one tree's runs over `seeds` in one process (`assembly.bench.run_batch`); a seed
    the process did not report is a run with status NO SUMMARY and the process's last words."""
    runs_dir = tmp / f"{tree.stem}-{mode}"
    command = [sys.executable, "-m", "assembly.bench.run_batch", str(tree), mode, str(cell), str(runs_dir),
               *map(str, seeds)]
    done = subprocess.run(command, check=False, capture_output=True, text=True)
    summaries = {}
    for line in done.stdout.splitlines():
        if line.startswith("{"):
            summary = json.loads(line)
            summaries[summary["seed"]] = summary
    lost = {"status": "NO SUMMARY", "message": done.stderr.strip()[-300:]}
    return [row_of(tree, mode, seed, summaries.get(seed, lost)) for seed in seeds]


def run(out: Path, quick: bool = False, seeds: int | None = None, modes: Iterable[str] | None = None,
        trees: Iterable[str] | None = None, jobs: int = 1) -> list[Path]:
    """Run the demo trees over `seeds` seeds (0..seeds-1) in `modes`, `jobs` runs at a time; write the
    table (markdown and JSON) and the chart."""
    chosen = list(trees or (QUICK_TREES if quick else ()))
    paths = [p for p in demo_trees(False) if not chosen or p.name in chosen or p.stem in chosen]
    modes = tuple(modes or (QUICK_MODES if quick else MODES))
    count = seeds or (QUICK_SEEDS if quick else SEEDS)
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        cell = randomised_cell(tmp)
        cases = [(tree, mode) for mode in modes for tree in paths]
        with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
            rows = []
            with open(out / "robustness_runs.jsonl", "w") as partial:  # each tree's runs as they finish
                def batch_of(case: tuple[Path, str]) -> list[dict]:
                    return run_seeds(case[0], case[1], list(range(count)), cell, tmp)

                for batch in pool.map(batch_of, cases):
                    rows += batch
                    partial.writelines(json.dumps(row) + "\n" for row in batch)
                    partial.flush()
    json_path = out / "robustness.json"
    json_path.write_text(json.dumps({"seeds": count, "modes": list(modes), "summary": table(rows), "runs": rows},
                                    indent=1) + "\n")
    md_path = out / "robustness.md"
    md_path.write_text(markdown(rows, count))
    (out / "robustness_runs.jsonl").unlink()
    return [json_path, md_path, chart(rows, out / "robustness.png")]


def _median(values: list[float]) -> float | None:
    return statistics.median(values) if values else None


def _spread(values: list[float]) -> tuple[float, float] | None:
    """The 10th and 90th percentiles."""
    if len(values) < 2:
        return (values[0], values[0]) if values else None
    deciles = statistics.quantiles(values, n=10, method="inclusive")
    return deciles[0], deciles[-1]


def table(rows: list[dict]) -> list[dict]:
    """Per (tree, mode): runs, successes, success rate, dishonest runs, the key metric's median and
    10-90 % spread, and for an assembly the median regret and placement error over its elements."""
    out = []
    for (tree, mode) in dict.fromkeys((r["tree"], r["mode"]) for r in rows):
        runs = [r for r in rows if r["tree"] == tree and r["mode"] == mode]
        values = [r["value"] for r in runs if r["value"] is not None]
        ok = sum(r["status"] == "SUCCESS" for r in runs)
        entry = {"tree": tree, "mode": mode, "runs": len(runs), "successes": ok, "success_rate": ok / len(runs),
                 "dishonest": sum(bool(r.get("dishonest")) for r in runs), "metric": runs[0]["metric"],
                 "median": _median(values), "p10_p90": _spread(values)}
        placed = [e for r in runs for e in r["placement_error_mm"]]
        if placed:
            entry["median_regret_pct"] = _median([x for r in runs for x in r["regret_pct"]])
            entry["median_placement_error_mm"] = _median(placed)
        out.append(entry)
    return out


def _num(value: float | None) -> str:
    return "" if value is None else f"{value:.3g}"


def markdown(rows: list[dict], seeds: int) -> str:
    """The table per tree and mode, then every failure and every dishonest run."""
    lines = ["# Demo trees on the randomised simulated cell", "",
             (f"Each tree run as `fvtree run TREE --perception MODE --seed N` (seeds 0-{seeds - 1}) on the sim "
              "cell with `world: {randomise: true}`: every seed draws its own sensor, skin, force sensor and "
              "scene from the ranges `fvtree scenes` lists. Success: the verdict (the tree's status checked "
              f"against the scene's truth) is SUCCESS; the goal is {GOAL:.0%} per demo and mode. Dishonest: "
              "SUCCESS with the key metric beyond the task's limit."), "",
             ("| tree | mode | success | rate | dishonest | key metric | median | p10-p90 | median regret (%) | "
              "median placement error (mm) |"), "|---|---|---|---|---|---|---|---|---|---|"]
    for t in table(rows):
        spread = t["p10_p90"]
        lines.append(f"| {t['tree']} | {t['mode']} | {t['successes']}/{t['runs']} | {t['success_rate']:.0%} | "
                     f"{t['dishonest']} | {t['metric']} | {_num(t['median'])} | "
                     f"{'' if spread is None else f'{spread[0]:.3g}-{spread[1]:.3g}'} | "
                     f"{_num(t.get('median_regret_pct'))} | {_num(t.get('median_placement_error_mm'))} |")
    failed = [r for r in rows if r["status"] != "SUCCESS" or r.get("dishonest")]
    lines += ["", "## Runs that failed or lied" if failed else "Every run succeeded honestly.", ""]
    for r in failed:
        why = r.get("why") or f"DISHONEST: {r['dishonest']}"
        lines.append(f"- {r['tree']}, {r['mode']}, seed {r['seed']} (skin lag {r['skin_lag_s']:g} s, force offset "
                     f"{r['force_offset_N']:g} N, rest jitter {r['rest_jitter_px']:g} px, gain x{r['gain']:g}): "
                     f"{r['status']} {why}".rstrip())
    return "\n".join([*lines, ""])


def chart(rows: list[dict], path: Path) -> Path:
    """Success rate per tree and mode (the goal dashed), and each tree's key metric per mode as boxes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    summary = table(rows)
    trees = list(dict.fromkeys(t["tree"] for t in summary))
    modes = list(dict.fromkeys(t["mode"] for t in summary))
    columns = 4
    panels = len(trees) + 1
    fig, axes = plt.subplots((panels + columns - 1) // columns, columns, squeeze=False,
                             figsize=(4.0 * columns, 3.0 * ((panels + columns - 1) // columns)))
    flat = axes.ravel()
    ax = flat[0]
    x = np.arange(len(trees))
    for i, mode in enumerate(modes):
        rates = [next((t["success_rate"] for t in summary if t["tree"] == tree and t["mode"] == mode), 0.0)
                 for tree in trees]
        ax.bar(x + (i - (len(modes) - 1) / 2) * 0.4, rates, 0.4, label=mode)
    ax.axhline(GOAL, color="#888", ls="--", lw=0.8)
    ax.set_xticks(x, [t.removesuffix(".yaml") for t in trees], rotation=60, ha="right", fontsize=6)
    ax.set_ylim(0, 1.05)
    ax.set_title("success rate (goal dashed)", fontsize=8)
    ax.legend(fontsize=6)
    for ax, tree in zip(flat[1:], trees):
        data = [[r["value"] for r in rows if r["tree"] == tree and r["mode"] == mode and r["value"] is not None]
                for mode in modes]
        if any(data):
            ax.boxplot([d or [np.nan] for d in data])
            ax.set_xticks(range(1, len(modes) + 1), modes)
        metric = next(t["metric"] for t in summary if t["tree"] == tree)
        ax.set_title(f"{tree.removesuffix('.yaml')}: {metric}", fontsize=7)
        ax.tick_params(labelsize=6)
    for ax in flat[panels:]:
        ax.axis("off")
    return save(fig, path)
