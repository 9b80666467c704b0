"""`fvtree bench demos`: every demo tree and the assembly run as `fvtree run` runs them, once with the
fast signals-mode perception and once with pixel mode (rendered fingertip frames through the real
FingerVision pipeline), side by side: the verdict (the tree's status checked against the scene's
truth), the exit code, every figure the scene reports, and the real-time factor. Writes demos.csv
(tree, mode, quantity, value), demos.md and demos.png.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

from assembly.bench import write_csv

TREES = Path(__file__).resolve().parents[2] / "trees"
MODES = ("signals", "pixels")
QUICK_TREES = ("press_with_force.yaml",)


def demo_trees(quick: bool) -> list[Path]:
    """The demo trees under trees/ (recording trees excluded: they only collect data)."""
    trees = sorted(p for p in TREES.glob("*.yaml") if not p.name.startswith("record_"))
    return [p for p in trees if p.name in QUICK_TREES] if quick else trees


def run_demo(tree: Path, mode: str, runs_dir: Path, seed: int = 0, cell: str = "sim") -> dict:
    """One `fvtree run TREE --cell CELL --perception MODE --seed SEED` in its own process: its summary
    with the exit code."""
    command = [sys.executable, "-m", "assembly.cli", "run", str(tree), "--cell", cell, "--perception", mode,
               "--seed", str(seed), "--runs-dir", str(runs_dir), "--no-plots", "--no-record"]
    done = subprocess.run(command, check=False, capture_output=True, text=True)
    summaries = sorted(runs_dir.glob("*/summary.json"))
    if not summaries:
        return {"status": "NO SUMMARY", "exit": done.returncode, "message": done.stderr.strip()[-300:]}
    summary = json.loads(summaries[-1].read_text())
    summary["exit"] = done.returncode
    return summary


def figures(summary: dict) -> dict:
    """The quantities a run is judged on: verdict, exit code, real-time factor, the scene's figures
    and, for an assembly, the largest regret of its placements; why a run did not succeed."""
    out = {"verdict": summary.get("status"), "exit code": summary.get("exit"),
           "real-time factor": summary.get("real_time_factor")}
    shortfalls = (summary.get("truth") or {}).get("shortfalls") or []
    if summary.get("status") != "SUCCESS":
        out["why"] = " ".join(str(summary.get(k) or "") for k in ("where", "message")).strip() + \
            "".join(f"; not done: {s}" for s in shortfalls)
    out.update(summary.get("metrics", {}))
    regrets = [e.get("regret") for e in summary.get("elements", {}).values() if e.get("regret") is not None]
    if regrets:
        out["largest regret (%)"] = round(100 * max(regrets), 4)
        out["elements placed"] = len(regrets)
    if shortfalls:
        out["not done"] = "; ".join(str(s) for s in shortfalls)
    return out


def run(out: Path, quick: bool = False) -> list[Path]:
    """Run each demo in both modes; write the table and the chart."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for tree in demo_trees(quick):
            for mode in MODES:
                runs_dir = Path(tmp) / f"{tree.stem}-{mode}"
                for quantity, value in figures(run_demo(tree, mode, runs_dir)).items():
                    rows.append({"tree": tree.name, "mode": mode, "quantity": quantity, "value": value})
    csv_path = write_csv(out / "demos.csv", rows, ["tree", "mode", "quantity", "value"])
    md_path = out / "demos.md"
    md_path.write_text(markdown(rows))
    return [csv_path, md_path, chart(rows, out / "demos.png")]


def side_by_side(rows: list[dict]) -> dict:
    """{(tree, quantity): {mode: value}} in the order the rows came."""
    table: dict = {}
    for r in rows:
        table.setdefault((r["tree"], r["quantity"]), {})[r["mode"]] = r["value"]
    return table


def _cell(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value).replace("|", "\\|")


def markdown(rows: list[dict]) -> str:
    """One line per tree and quantity, signals and pixel mode side by side."""
    lines = ["# Demo trees in both perception modes", "",
             ("Each tree run as `fvtree run TREE --perception MODE` on the simulated cell (seed 0). The verdict "
              "is the tree's status checked against the scene's truth (TASK_FAILED: the tree said SUCCESS but "
              "the task was not done)."), "",
             "| tree | quantity | signals | pixels |", "|---|---|---|---|"]
    for (tree, quantity), by_mode in side_by_side(rows).items():
        lines.append(f"| {tree} | {quantity} | {_cell(by_mode.get('signals', ''))} | {_cell(by_mode.get('pixels', ''))} |")
    verdicts = {mode: sum(r["value"] == "SUCCESS" for r in rows if r["mode"] == mode and r["quantity"] == "verdict")
                for mode in MODES}
    count = len({r["tree"] for r in rows})
    lines += ["", (f"SUCCESS in signals mode: {verdicts['signals']} of {count}; in pixel mode: "
                   f"{verdicts['pixels']} of {count}."), ""]
    return "\n".join(lines)


def chart(rows: list[dict], path: Path) -> Path:
    """Real-time factor of each demo in both modes, bars hatched where the verdict is not SUCCESS."""
    table = side_by_side(rows)
    trees = sorted({r["tree"] for r in rows})
    rtf = {mode: [float(table.get((t, "real-time factor"), {}).get(mode) or 0.0) for t in trees] for mode in MODES}
    fig, ax, bars = mode_bars(trees, rtf)
    for mode in MODES:
        for bar, tree in zip(bars[mode], trees):
            if table.get((tree, "verdict"), {}).get(mode) != "SUCCESS":
                bar.set_hatch("xx")
                bar.set_edgecolor("#d33")
    ax.axhline(10, color="#888", ls="--", lw=0.8, label="10x")
    ax.set_yscale("log")
    ax.set_ylabel("real-time factor")
    ax.set_title("demo trees: signals against pixel mode (hatched: not SUCCESS)")
    ax.legend()
    return save(fig, path)


def mode_bars(trees: list[str], values: dict[str, list[float]]):
    """A figure with a bar per perception mode for each tree, side by side: (figure, axes, {mode:
    bars}); the caller labels it and saves it with `save`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    x = np.arange(len(trees))
    fig, ax = plt.subplots(figsize=(max(6.0, 0.8 * len(trees) + 2), 4))
    bars = {mode: ax.bar(x + (i - 0.5) * 0.4, values[mode], 0.4, color=colour, label=f"{mode} mode")
            for i, (mode, colour) in enumerate(zip(MODES, ("#4682e6", "#e69a46")))}
    ax.set_xticks(x, [t.removesuffix(".yaml") for t in trees], rotation=30, ha="right")
    return fig, ax, bars


def save(fig, path: Path) -> Path:
    """Lay out, write and close a benchmark figure."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
