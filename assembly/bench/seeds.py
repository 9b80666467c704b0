"""`fvtree bench seeds`: how often each demo tree does its task, over several seeds, in both
perception modes. A skill tuned on one seed can pass by luck; this runs every demo tree as `fvtree
run TREE --perception MODE --seed N` (seeds 0-9 in signals mode, 0-4 in the slower pixel mode)
and counts the runs whose verdict, the tree's status checked against the scene's truth, is
SUCCESS. Writes seeds.csv (tree, mode, seed, verdict, why), seeds.md and seeds.png.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from assembly.bench import write_csv
from assembly.bench.demos import MODES, demo_trees, figures, mode_bars, run_demo, save

SEEDS = {"signals": range(10), "pixels": range(5)}
QUICK_SEEDS = (1,)  # --quick: one seed other than the demos bench's 0


def run(out: Path, quick: bool = False) -> list[Path]:
    """Run each demo tree over the seeds of each mode; write the table and the chart."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for tree in demo_trees(quick):
            for mode in MODES:
                for seed in QUICK_SEEDS if quick else SEEDS[mode]:
                    result = figures(run_demo(tree, mode, Path(tmp) / f"{tree.stem}-{mode}-{seed}", seed))
                    rows.append({"tree": tree.name, "mode": mode, "seed": seed, "verdict": result["verdict"],
                                 "why": result.get("why", "")})
    csv_path = write_csv(out / "seeds.csv", rows, ["tree", "mode", "seed", "verdict", "why"])
    md_path = out / "seeds.md"
    md_path.write_text(markdown(rows))
    return [csv_path, md_path, chart(rows, out / "seeds.png")]


def tally(rows: list[dict]) -> dict[tuple[str, str], tuple[int, int]]:
    """{(tree, mode): (runs that succeeded, runs)}."""
    out: dict[tuple[str, str], tuple[int, int]] = {}
    for r in rows:
        ok, n = out.get((r["tree"], r["mode"]), (0, 0))
        out[(r["tree"], r["mode"])] = (ok + (r["verdict"] == "SUCCESS"), n + 1)
    return out


def markdown(rows: list[dict]) -> str:
    """Successes per tree and mode, then every run that did not succeed with why."""
    counts = tally(rows)
    trees = sorted({r["tree"] for r in rows})
    lines = ["# Demo trees over several seeds", "",
             ("Each tree run as `fvtree run TREE --perception MODE --seed N` on the simulated cell; a run counts "
              "when its verdict (the tree's status checked against the scene's truth) is SUCCESS."), "",
             "| tree | signals | pixels |", "|---|---|---|"]
    for tree in trees:
        cells = [("{}/{}".format(*counts[(tree, mode)]) if (tree, mode) in counts else "") for mode in MODES]
        lines.append(f"| {tree} | {cells[0]} | {cells[1]} |")
    failed = [r for r in rows if r["verdict"] != "SUCCESS"]
    lines += ["", "Runs that did not succeed:" if failed else "Every run succeeded.", ""]
    lines += [f"- {r['tree']}, {r['mode']} mode, seed {r['seed']}: {r['verdict']} {r['why']}".rstrip() for r in failed]
    return "\n".join([*lines, ""])


def chart(rows: list[dict], path: Path) -> Path:
    """Share of successful runs per tree and mode, with the counts written on the bars."""
    counts = tally(rows)
    trees = sorted({r["tree"] for r in rows})
    ok_n = {mode: [counts.get((t, mode), (0, 0)) for t in trees] for mode in MODES}
    fig, ax, bars = mode_bars(trees, {mode: [ok / n if n else 0.0 for ok, n in ok_n[mode]] for mode in MODES})
    for mode in MODES:
        for bar, (ok, n) in zip(bars[mode], ok_n[mode]):
            ax.annotate(f"{ok}/{n}", (bar.get_x() + bar.get_width() / 2, bar.get_height()), ha="center",
                        va="bottom", fontsize=7)
    ax.set_ylim(0, 1.15)
    ax.set_ylabel("runs that did the task")
    ax.set_title("demo trees over several seeds (verdict against the scene's truth)")
    ax.legend(loc="lower right")
    return save(fig, path)
