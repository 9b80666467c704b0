"""The summary of a run, typed: its status, where and why it ended, timing, safety, the scene's
metrics and, per element of the design, its as-built data with the world's truth about it (from
the simulated world, judged when the element was placed: a resumed run keeps the figures of what
was placed before it), and the verdict of the scene's truth. `summary.json` holds it as JSON."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from assembly.design.model import DesignModel
from assembly.outcome.result import RunResult
from assembly.outcome.verdict import TASK_FAILED, Verdict
from drivers.cell import Cell
from fvfiles.json_files import atomic_write_json, to_jsonable

CURVE = "true_load_curve"  # a world's truth per element: the true load along the plate, for charts
SUMMARY_FILE = "summary.json"


@dataclass
class Summary:
    """What a run did. `elements` maps each element of the design to its status, as-built pose and
    measured load, and in simulation the scene's truth about it (position, regret, ...); `truth`
    is the verdict of a simulated scene's truth; `tree_status` the tree's own status when that
    verdict overruled it (TASK_FAILED)."""

    status: str  # SUCCESS | FAILURE | HALTED | ESTOP | TIMEOUT | FAULT | CRASHED | TASK_FAILED
    message: str = ""
    where: str = ""
    metrics: dict[str, Any] = field(default_factory=dict)
    ticks: int = 0
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    real_time_factor: float = 0.0
    safety_clamps: int = 0
    arm_fault: str | None = None
    gripper_fault: str | None = None
    elements: dict[str, dict[str, Any]] = field(default_factory=dict)
    run_dir: str | None = None
    truth: Verdict | None = None
    tree_status: str | None = None
    substitutions: list[dict] = field(default_factory=list)  # nodes replaced by test doubles
    plot: str | None = None  # the load-profile chart, when one was drawn
    traceback: str = ""  # CRASHED: where the exception came from
    nothing_to_do: bool = False  # a resumed run whose elements were all placed already
    lost: list[str] = field(default_factory=list)  # what disk trouble kept from being written (file: from when, why)
    # the supervisor's worst tick gap, arm data age and perception age beside their limits (s)
    margins: dict[str, dict[str, float]] = field(default_factory=dict)

    def apply(self, verdict: Verdict) -> None:
        """Take the verdict of the scene's truth: a tree that succeeded with shortfalls ends
        TASK_FAILED, its own status kept as `tree_status`."""
        self.truth = verdict
        if verdict.shortfalls and self.status == "SUCCESS":
            self.tree_status, self.status = self.status, TASK_FAILED
            self.message = "the tree succeeded but the scene's truth shows the task was not done"

    def to_json(self) -> dict[str, Any]:
        """The summary as `summary.json` holds it: optional entries only when they say something."""
        data = json.loads(json.dumps(asdict(self), default=to_jsonable))
        for key in ("truth", "tree_status", "traceback"):
            if not data[key]:
                del data[key]
        for key in ("substitutions", "nothing_to_do", "lost", "margins"):
            if not data[key]:
                del data[key]
        return data

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Summary:
        """A summary read back from `summary.json` (unknown entries are left out)."""
        known = {f.name for f in fields(cls)}
        values = {k: v for k, v in data.items() if k in known}
        if isinstance(values.get("truth"), dict):
            values["truth"] = Verdict(**values["truth"])
        return cls(**{"status": "", **values})

    def write(self, run_dir: Path) -> None:
        """Replace the run directory's `summary.json` atomically."""
        atomic_write_json(run_dir / SUMMARY_FILE, self.to_json())


def summarize(result: RunResult, cell: Cell, design: DesignModel | None,
              kept: dict[str, dict] | None = None) -> Summary:
    """The summary of a finished tick loop on `cell`; `kept` entries (elements placed before a
    resume, from the earlier summary) stay as they were."""
    world = cell.world
    truth = world.truth() if world is not None else {}
    kept = kept or {}
    elements: dict[str, dict[str, Any]] = {}
    if design is not None:
        for eid in design.build_order():
            elements[eid] = kept[eid] if eid in kept else _element(design, eid, truth.get(eid, {}))
    return Summary(
        status=result.status, message=result.message, where=result.where,
        metrics=world.metrics() if world is not None else {},
        ticks=result.ticks, sim_time_s=round(result.sim_time, 3), wall_time_s=round(result.wall_time, 3),
        real_time_factor=round(result.real_time_factor, 1),
        safety_clamps=cell.arm.clamped, arm_fault=cell.arm.fault(), gripper_fault=cell.gripper.fault(),
        elements=elements, traceback=result.traceback, margins=result.margins)


def _element(design: DesignModel, eid: str, truth: dict[str, Any]) -> dict[str, Any]:
    """An element's status, as-built pose and measured load, with the world's truth about it."""
    node = design.graph.nodes[eid]
    entry = {"status": node.get("status", "planned"), "measured_load_px": node.get("measured_load"),
             "asbuilt_pose": node.get("asbuilt_pose")}
    entry.update((k, v) for k, v in truth.items() if k != CURVE)
    return entry


def format_summary(summary: Summary) -> str:
    """The summary as the lines `fvtree run` prints."""
    lines = [f"{summary.status}" + (f": {summary.message}" if summary.message else "")]
    if summary.status not in ("SUCCESS", "TASK_FAILED") and summary.where:
        lines.append(f"  stopped at: {summary.where}")
    truth = summary.truth
    lines += [f"  not done: {shortfall}" for shortfall in (truth.shortfalls if truth else [])]
    lines += [f"  not judged: {note}" for note in (truth.unjudged if truth else [])]
    placed = [e for e in summary.elements.values() if e["status"] == "placed"]
    if summary.elements:
        lines.append(f"  elements placed: {len(placed)} of {len(summary.elements)}")
    for eid, e in summary.elements.items():
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
    for name, value in summary.metrics.items():
        lines.append(f"  {name}: {value:.4g}" if isinstance(value, float) else f"  {name}: {value}")
    if truth and truth.tolerances:
        lines.append("  judged by the scene's truth with " + ", ".join(f"{k} {v:g}" for k, v in truth.tolerances.items()))
    lines += [f"  lost: {what}" for what in summary.lost]
    lines.append(f"  sim time {summary.sim_time_s:.1f} s, wall time {summary.wall_time_s:.2f} s, "
                 f"real-time factor {summary.real_time_factor:.0f}x, {summary.ticks} ticks")
    return "\n".join(lines)
