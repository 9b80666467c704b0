"""Benchmark output: CSV and Markdown tables, PNG charts (matplotlib, Agg backend)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

from assembly.bench import write_csv

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def write_table(out: Path, name: str, rows: Sequence[dict], title: str, notes: str = "") -> list[Path]:
    """Write rows as `<name>.csv` and `<name>.md`; returns both paths."""
    keys = list(rows[0])
    csv_path, md_path = out / f"{name}.csv", out / f"{name}.md"
    write_csv(csv_path, rows, keys)
    lines = [f"# {title}", ""] + ([notes, ""] if notes else [])
    lines += ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(_fmt(r[k]) for k in keys) + " |" for r in rows]
    md_path.write_text("\n".join(lines) + "\n")
    return [csv_path, md_path]


def chart_accuracy_speed(out: Path, rows: Sequence[dict]) -> Path:
    """Per-frame time against marker error, one point per detector/tracker/filter combination: at
    noise sigma 4, under a 20 px shear and under a textured object (x: the method breaks there)."""
    panels = [("rms_px", "marker RMS error, px (noise sigma 4)", 0.2, None),
              ("shear20_rms_px", "marker RMS error, px (20 px shear)", 0.3, "shear20_tracked"),
              ("textured40_off_1px", "trusted samples > 1 px off (textured 40 %)", 0.005, None)]
    fig, axes = plt.subplots(1, len(panels), figsize=(19, 5.5))
    markers = {"none": "o", "thesis": "s", "gated": "^"}
    for ax, (key, label, goal, tracked) in zip(axes, panels):
        for r in rows:
            y = r[key] if r[key] == r[key] else 5.0  # nan: nothing tracked
            broken = y > goal or (tracked is not None and r[tracked] < 0.97)
            ax.scatter(r["ms_per_frame"], max(y, 1e-4), marker="x" if broken else markers[r["filter"]], s=60)
            ax.annotate(f"{r['tracker']}/{r['detector']}/{r['filter']}", (r["ms_per_frame"], max(y, 1e-4)),
                        fontsize=6, xytext=(4, 3), textcoords="offset points")
        ax.axhline(goal, ls="--", c="grey", lw=1)
        ax.axvline(1000 / 1500, ls=":", c="grey", lw=1)
        ax.text(1000 / 1500, ax.get_ylim()[1], " 1500 fps", fontsize=7, va="top")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("markers + filter + wrench, ms per frame (median, one core)")
        ax.set_ylabel(label)
    fig.suptitle("Speed against accuracy (o: no filter, s: thesis KF, ^: gated KF, x: past the goal line "
                 "or < 97 % tracked)")
    return _save(fig, out / "accuracy_speed.png")


def chart_slip(out: Path, rows: Sequence[dict]) -> Path:
    """Slip detection F1 against time per frame of the slip stage, per method and condition."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for r in rows:
        ax.scatter(r["ms_per_frame"], r["f1"], s=60)
        ax.annotate(f"{r['method']} ({r['condition']})", (r["ms_per_frame"], r["f1"]), fontsize=8,
                    xytext=(4, 3), textcoords="offset points")
    ax.set_xlabel("slip stage (motion + object restriction), ms per frame")
    ax.set_ylabel("slip F1 (threshold tuned on another sequence)")
    ax.set_ylim(0, 1.05)
    ax.set_title("Slip detection: quality against time")
    return _save(fig, out / "slip.png")


def chart_sweeps(out: Path, rows: Sequence[dict], factors: Sequence[str], name: str = "sweeps.png") -> Path:
    """Error against each disturbance, one line per method; x marks where a method breaks."""
    fig, axes = plt.subplots(1, len(factors), figsize=(4 * len(factors), 4), squeeze=False)
    methods = list(dict.fromkeys(r["method"] for r in rows))
    for ax, factor in zip(axes[0], factors):
        for i, method in enumerate(methods):
            pts = [r for r in rows if r["factor"] == factor and r["method"] == method]
            x = [r["value"] for r in pts]
            y = [5.0 if r["rms_px"] != r["rms_px"] else min(r["rms_px"], 5.0) for r in pts]  # nan: lost
            line, = ax.plot(x, y, "-o", ms=3, label=method)
            broken = [(x[i], y[i]) for i, r in enumerate(pts) if r["broken"]]
            if broken:
                ax.scatter(*zip(*broken), marker="x", s=70, color=line.get_color(), zorder=3)
        ax.axhline(0.5, ls="--", c="grey", lw=1)
        ax.set_yscale("log")
        ax.set_xlabel(factor)
        ax.set_title(factor)
    axes[0][0].set_ylabel("marker RMS error, px (5 = clipped or nothing tracked)")
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Stability sweeps: x = broken (RMS > 0.5 px, < 50 % tracked, unflagged swaps, or biased)")
    return _save(fig, out / name)


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
