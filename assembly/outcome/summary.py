"""Run summaries: per placed element, the chosen position against the true maximum-load
position with the force regret (from the simulated world's truth, judged when the element was
placed: a resumed run keeps the figures of what was placed before it), the scene's metrics, the
arm and gripper faults, sim and wall time, and a load-profile chart."""

from __future__ import annotations

import json
from pathlib import Path

from assembly.design.model import DesignModel
from assembly.outcome.result import RunResult
from drivers.cell import Cell
from fileio.json_files import atomic_write_json, to_jsonable

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


def write_summary(summary: dict, run_dir: Path) -> None:
    atomic_write_json(run_dir / "summary.json", json.loads(json.dumps(summary, default=to_jsonable)))
