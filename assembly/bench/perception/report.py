"""Benchmark output: CSV and Markdown tables, PNG charts (matplotlib, Agg backend)."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def write_table(out: Path, name: str, rows: Sequence[dict], title: str, notes: str = "") -> list[Path]:
    """Write rows as `<name>.csv` and `<name>.md`; returns both paths."""
    keys = list(rows[0])
    csv_path, md_path = out / f"{name}.csv", out / f"{name}.md"
    with csv_path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    lines = [f"# {title}", ""] + ([notes, ""] if notes else [])
    lines += ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(_fmt(r[k]) for k in keys) + " |" for r in rows]
    md_path.write_text("\n".join(lines) + "\n")
    return [csv_path, md_path]


def chart_accuracy_speed(out: Path, rows: Sequence[dict]) -> Path:
    """Per-frame time against marker RMS error, one point per detector/tracker/filter combination."""
    fig, ax = plt.subplots(figsize=(8, 5.5))
    markers = {"none": "o", "thesis": "s", "gated": "^"}
    for r in rows:
        ax.scatter(r["ms_per_frame"], r["rms_px"], marker=markers[r["filter"]], s=60)
        ax.annotate(f"{r['tracker']}/{r['detector']}/{r['filter']}", (r["ms_per_frame"], r["rms_px"]),
                    fontsize=7, xytext=(4, 3), textcoords="offset points")
    ax.axhline(0.2, ls="--", c="grey", lw=1)
    ax.axvline(1000 / 1500, ls=":", c="grey", lw=1)
    ax.text(1000 / 1500, ax.get_ylim()[1], " 1500 fps", fontsize=7, va="top")
    ax.set_xscale("log")
    ax.set_xlabel("markers + filter + wrench, ms per frame (median, one core)")
    ax.set_ylabel("marker RMS position error, px (noise sigma 4)")
    ax.set_title("Speed against accuracy (o: no filter, s: thesis KF, ^: gated KF)")
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


def chart_sweeps(out: Path, rows: Sequence[dict], factors: Sequence[str]) -> Path:
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
    fig.suptitle("Stability sweeps: x = broken (RMS > 0.5 px, < 50 % tracked, or unflagged swaps)")
    return _save(fig, out / "sweeps.png")


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
