"""Run summaries: per placed element, the chosen position against the true maximum-load
position with the force regret (from the simulated world's truth, judged when the element was
placed: a resumed run keeps the figures of what was placed before it), the scene's metrics, the
arm and gripper faults, sim and wall time, and a load-profile chart."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from assembly.design import DesignModel
from assembly.files import atomic_write_json, to_jsonable
from assembly.runner import RunResult
from drivers.cell import Cell
from drivers.protocols import World

CURVE = "true_load_curve"  # a world's truth per element: the true load along the plate, for charts


def summarize(result: RunResult, cell: Cell, design: DesignModel | None,
              kept: dict[str, dict] | None = None) -> dict:
    """The run's summary: status, where it stopped, timing, safety, the scene's metrics and, per
    element of the design, its as-built data with the world's truth about it (simulation only);
    `kept` entries (elements placed before a resume, from the earlier summary) stay as they were."""
    truth = cell.world.truth() if cell.world is not None else {}
    kept = kept or {}
    elements = {}
    for eid in (design.build_order() if design else []):
        if eid in kept:
            elements[eid] = kept[eid]
            continue
        node = design.graph.nodes[eid]
        entry = {"status": node.get("status", "planned"), "measured_load_px": node.get("measured_load"),
                 "asbuilt_pose": node.get("asbuilt_pose")}
        entry.update((k, v) for k, v in truth.get(eid, {}).items() if k != CURVE)
        elements[eid] = entry
    metrics = cell.world.metrics() if cell.world is not None else {}
    return {
        "status": result.status, "message": result.message, "where": result.where,
        "metrics": metrics,
        "ticks": result.ticks, "sim_time_s": round(result.sim_time, 3),
        "wall_time_s": round(result.wall_time, 3),
        "real_time_factor": round(result.real_time_factor, 1),
        "safety_clamps": cell.arm.clamped, "arm_fault": cell.arm.fault(), "gripper_fault": cell.gripper.fault(),
        "elements": elements,
    }


def format_summary(summary: dict) -> str:
    lines = [f"{summary['status']}" + (f": {summary['message']}" if summary["message"] else "")]
    if summary["status"] not in ("SUCCESS", "TASK_FAILED") and summary["where"]:
        lines.append(f"  stopped at: {summary['where']}")
    truth = summary.get("truth", {})
    lines += [f"  not done: {shortfall}" for shortfall in truth.get("shortfalls", [])]
    placed = [e for e in summary["elements"].values() if e["status"] == "placed"]
    if summary["elements"]:
        lines.append(f"  elements placed: {len(placed)} of {len(summary['elements'])}")
    for eid, e in summary["elements"].items():
        if "position" in e:
            lines.append(
                f"  {eid} on {e['plate']}: placed at {e['position']:.4f} m, true max-load position "
                f"{e['true_best_position']:.4f} m ({(e['position'] - e['true_best_position']) * 1000:+.1f} mm); "
                f"load {e['load_N']:.2f} N of {e['true_max_load_N']:.2f} N max, "
                f"regret {e['regret'] * 100:.3f} %")
        elif e["status"] == "placed":
            lines.append(f"  {eid}: placed at {e['asbuilt_pose'][:3]}, measured load {e['measured_load_px']}")
        elif e["status"] == "placing":
            lines.append(f"  {eid}: being released when the run stopped: check it before resuming")
    for name, value in summary.get("metrics", {}).items():
        lines.append(f"  {name}: {value:.4g}" if isinstance(value, float) else f"  {name}: {value}")
    if truth.get("tolerances"):
        lines.append("  judged by the scene's truth with " + ", ".join(f"{k} {v:g}" for k, v in truth["tolerances"].items()))
    lines.append(f"  sim time {summary['sim_time_s']:.1f} s, wall time {summary['wall_time_s']:.2f} s, "
                 f"real-time factor {summary['real_time_factor']:.0f}x, {summary['ticks']} ticks")
    return "\n".join(lines)


def plot_profiles(profiles: dict[str, dict], summary: dict, world: World | None, path: Path) -> Path | None:
    """One panel per element: measured load along the plate, smoothing, chosen point and, from
    the world's truth, the true load curve and its maximum."""
    if not profiles:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    truth = world.truth() if world is not None else {}
    fig, axes = plt.subplots(len(profiles), 1, figsize=(8, 3.2 * len(profiles)), squeeze=False)
    for ax, (eid, prof) in zip(axes[:, 0], profiles.items()):
        x = np.asarray(prof["position"])
        ax.plot(x, prof["load"], ".", ms=2, color="0.6", label="measured (FingerVision)")
        ax.plot(x, prof["smoothed"], color="C0", label="smoothed")
        ax.axvline(prof["best_position"], color="C0", ls="--", label=f"chosen {prof['best_position']:.3f} m")
        ax.set_ylabel("load in the grip [px]")
        if CURVE in truth.get(eid, {}):
            curve = truth[eid][CURVE]
            shown = (curve["position"] >= x.min()) & (curve["position"] <= x.max())
            twin = ax.twinx()
            twin.plot(curve["position"][shown], curve["load_N"][shown], color="C3", lw=1, label="true R(a) [N]")
            twin.set_ylabel("true load as placed [N]", color="C3")
            ax.axvline(truth[eid]["true_best_position"], color="C3", ls=":",
                       label=f"true max {truth[eid]['true_best_position']:.3f} m")
        ax.set_title(f"{eid}: load along plate {prof.get('plate', '')}")
        ax.set_xlabel("position along the span a [m]")
        ax.legend(loc="lower center", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_summary(summary: dict, run_dir: Path) -> None:
    atomic_write_json(run_dir / "summary.json", json.loads(json.dumps(summary, default=to_jsonable)))
