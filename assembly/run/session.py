"""One `fvtree run`: load and validate the tree, set up the run directory and the design bridge
(resuming a previous run if asked), build the cell, tick to the end under the cell supervisor,
report. The cell is closed whatever happens once it is built, and SIGTERM halts the run like
Ctrl-C."""

from __future__ import annotations

import gc
import json
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from assembly.design.bridge import DesignBridge
from assembly.design.model import DesignModel
from assembly.errors import TreeError
from assembly.language.build import build
from assembly.language.reader import TreeDocument, load_tree, with_scene
from assembly.language.substitution import Rule, substitute
from assembly.observe import IMAGE_HZ
from assembly.observe.recorder import run_recorder
from assembly.outcome.charts import plot_profiles
from assembly.outcome.summary import format_summary, summarize, write_summary
from assembly.outcome.verdict import judge, tolerances_for
from assembly.run.loop import Runner
from assembly.run.perception_stage import clear_blackboard
from assembly.run.progress import end_stderr_progress, stderr_progress
from assembly.run.run_dir import ASBUILT_FILE, SUMMARY_FILE, find_run, new_run_dir, write_run_file
from assembly.run.supervisor import Supervision
from assembly.signals import sigterm_raises_terminated
from drivers.cell_builders import load_cell

MARKS = ("placed", "planned")  # what a person may mark an element left `placing`


@sigterm_raises_terminated()  # from the start: SIGTERM while the cell is set up closes it like Ctrl-C
def run_tree(tree_path: str, cell: str = "sim", seed: int = 0, realtime: bool = False,
             perception: str | None = None, runs_dir: Path = Path("runs"), resume: str | None = None,
             estop_at: float | None = None, max_time: float = 3600.0, plots: bool = True,
             quiet: bool = False, marks: dict[str, str] | None = None, scene: str | None = None,
             record: bool = True, live: str | None = None, bridge_url: str | None = None,
             cell_name: str | None = None, coordinated: bool = False,
             substitutions: list[Rule] | None = None, record_images: float = IMAGE_HZ) -> dict:
    """Run a tree file end to end; returns the summary (also written to the run directory).

    `marks` ({element: placed|planned}, resuming only) records a person's check of elements a
    stopped run left being placed; `scene` replaces the tree's simulated scene. `record` writes
    the run's Rerun recording into the run directory; `live` streams it to a viewer at that URL;
    `record_images` is the rate of camera frames in it (per second of cell time, 0: none).
    `bridge_url` (mqtt://HOST:PORT) links the design bridge live to designers under `cell_name`
    (default: the tree's name); `coordinated` takes the elements from a design coordinator.
    `substitutions` replace nodes by path or glob with test doubles (`assembly.language.substitution`)."""
    doc = load_tree(tree_path)
    if scene is not None:
        doc = with_scene(doc, scene)
    doc, substituted = substitute(doc, substitutions or [])
    supervision = Supervision.of_cell(cell)
    if (coordinated or cell_name) and not bridge_url:
        raise TreeError("--coordinated and --cell-name name this cell on a broker", str(tree_path),
                        hint="add --bridge mqtt://HOST:PORT")
    clear_blackboard()
    before: dict = {}
    if resume:
        run_dir = find_run(runs_dir, resume, doc)
        before = _previous_summary(run_dir)
        bridge = _resumed_bridge(run_dir, doc, marks or {})
        if bridge is None:
            return _nothing_to_do(run_dir, before, quiet)
    else:
        if marks:
            raise TreeError("--mark records a check of a stopped run: use it with --resume", str(tree_path))
        run_dir = new_run_dir(runs_dir, doc.name)
        write_run_file(run_dir, doc, cell=cell, seed=seed)
        bridge = (DesignBridge(doc.design, run_dir / ASBUILT_FILE, run_dir / "events.jsonl")
                  if doc.design is not None else None)
    if bridge is not None and bridge_url:
        from assembly.design.link.mqtt_bridge import attach

        attach(bridge, bridge_url, cell_name or doc.name, coordinated)
    design = bridge.model if bridge else None
    placed_before = [e for e in design.build_order() if design.is_placed(e)] if design else []
    # The simulated world is built from the original design: what is already placed stands.
    scene_args = doc.design.scene_args() if doc.design is not None else {}
    the_cell = load_cell(cell, doc.tick_hz, doc.scene, scene_args, seed=seed, perception=perception)
    try:
        tolerances = tolerances_for(doc, the_cell.world) if the_cell.world is not None else {}
        if placed_before and the_cell.world is not None:
            _stand_placed(the_cell.world, design, placed_before)
        built = build(doc)
        recorder = (run_recorder(built, the_cell, run_dir, design, record, live, record_images)
                    if record or live else None)
        runner = Runner(built, the_cell, run_dir, bridge, realtime=realtime,
                        progress=None if quiet else stderr_progress, estop_at=estop_at, max_time=max_time,
                        supervision=supervision, recorder=recorder)
        if bridge:
            bridge.event("start", tree=str(tree_path), cell=cell, seed=seed, resume=bool(resume))
        runner.setup()
        with _frozen_heap():
            result = runner.run()
    finally:
        the_cell.close()
    if not quiet:
        end_stderr_progress()
    summary = summarize(result, the_cell, design, {e: before["elements"][e] for e in placed_before
                                                   if e in before.get("elements", {})})
    summary["run_dir"] = str(run_dir)
    if substituted:
        summary["substitutions"] = substituted
    if the_cell.world is not None:
        judge(summary, the_cell.world, tolerances)
    _finish(summary, result, the_cell, run_dir, plots)
    if bridge:
        bridge.event("end", status=summary["status"], where=result.where, message=summary["message"])
        bridge.close()
    elif recorder is not None:  # no event log for the recorder to read the end from: tell it
        recorder.event("end", status=summary["status"], where=result.where, message=summary["message"])
    if recorder is not None:
        recorder.finish()
    if not quiet:
        print(format_summary(summary))
        for made in substituted:
            print(f"  substituted: {made['path']} ({made['was']}) by {made['double']}")
        print(f"  run directory: {run_dir}" + (f" (chart: {summary.get('plot')})" if summary.get("plot") else ""))
    return summary


def _finish(summary: dict, result, cell, run_dir: Path, plots: bool) -> None:
    """Chart and summary file; a run directory that cannot be written loses them, not the run."""
    if result.traceback:
        summary["traceback"] = result.traceback
    try:
        if plots:
            png = plot_profiles(result.profiles, summary, cell.world, run_dir / "load_profiles.png")
            summary["plot"] = str(png) if png else None
        write_summary(summary, run_dir)
    except OSError as exc:
        print(f"cannot write the summary to {run_dir} ({exc.strerror or exc})", file=sys.stderr)


def _previous_summary(run_dir: Path) -> dict:
    """The summary an earlier session of this run wrote, if any."""
    try:
        return json.loads((run_dir / SUMMARY_FILE).read_text())
    except (OSError, ValueError):
        return {}


def _resumed_bridge(run_dir: Path, doc: TreeDocument, marks: dict[str, str]) -> DesignBridge | None:
    """The design bridge of a run to resume, caught up with its event log and a person's marks;
    None when nothing is left to build. An element left `placing` stops the resume."""
    bridge = DesignBridge(DesignModel.load(run_dir / ASBUILT_FILE), run_dir / ASBUILT_FILE,
                          run_dir / "events.jsonl")
    bridge.catch_up()
    design = bridge.model
    for eid, status in marks.items():
        if eid not in design.elements():
            raise TreeError(f"--mark {eid}={status}: no element {eid!r} in the design", str(run_dir / ASBUILT_FILE))
        if design.graph.nodes[eid].get("status") != "placing":
            raise TreeError(f"--mark {eid}={status}: {eid} is {design.graph.nodes[eid].get('status', 'planned')!r}, "
                            "not 'placing'; only an element left being placed needs a mark", str(run_dir / ASBUILT_FILE))
        bridge.mark(eid, status)
    for eid in design.build_order():
        node = design.graph.nodes[eid]
        if node.get("status") == "placing":
            pose = np.round(node.get("asbuilt_pose") or [np.nan] * 3, 3)[:3].tolist()
            raise TreeError(
                f"element {eid} was being released on plate {node.get('plate')} at {pose} when the run stopped: "
                "it may stand there, still be in the gripper, or have fallen, so it is not picked again",
                str(run_dir / ASBUILT_FILE),
                hint=f"check the cell, then resume with --mark {eid}=placed (it stands there) "
                     f"or --mark {eid}=planned (remove it first; it will be built again)")
    if all(design.is_placed(e) for e in design.build_order()) and design.build_order():
        return None
    return bridge


def _nothing_to_do(run_dir: Path, before: dict, quiet: bool) -> dict:
    """The summary of a run that has already placed every element."""
    summary = {**before, "run_dir": str(run_dir), "nothing_to_do": True}
    if not quiet:
        print(f"nothing to do: every element of {run_dir} is placed"
              + (f" (the run ended {before['status']})" if before.get("status") else ""))
    return summary


@contextmanager
def _frozen_heap() -> Iterator[None]:
    """Collect once, then keep every object alive so far out of the garbage collector's view
    while the tick loop runs: a full collection over them pauses it for 100 ms or more."""
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _stand_placed(world, design: DesignModel, placed: list[str]) -> None:
    """On resume in simulation, put already-placed elements where the as-built model says."""
    for eid in placed:
        world.stand(eid, np.array(design.graph.nodes[eid]["asbuilt_pose"], float))
