"""One `fvtree run`: load and validate the tree, set up the run directory and the design bridge
(resuming a previous run if asked), build the cell, tick to the end, report."""

from __future__ import annotations

import gc
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from assembly.blackboard import clear_blackboard
from assembly.design import DesignBridge, DesignModel
from assembly.errors import TreeError
from assembly.loader import build, load_tree
from assembly.progress import end_stderr_progress, stderr_progress
from assembly.report import format_summary, plot_profiles, summarize, write_summary
from assembly.run_dir import new_run_dir
from assembly.runner import Runner
from drivers.cell_builders import load_cell


def _resume_dir(runs_dir: Path, resume: str, tree_name: str) -> Path:
    if resume != "latest":
        path = Path(resume)
        if not (path / "asbuilt.json").exists():
            raise TreeError("not a run directory with an as-built model (asbuilt.json)", str(path))
        return path
    candidates = sorted(p for p in runs_dir.glob(f"*-{tree_name}*") if (p / "asbuilt.json").exists())
    if not candidates:
        raise TreeError(f"no earlier run of {tree_name!r} to resume", str(runs_dir))
    return candidates[-1]


def run_tree(tree_path: str, cell: str = "sim", seed: int = 0, realtime: bool = False,
             perception: str | None = None, runs_dir: Path = Path("runs"), resume: str | None = None,
             estop_at: float | None = None, max_time: float = 3600.0, plots: bool = True,
             quiet: bool = False) -> dict:
    """Run a tree file end to end; returns the summary (also written to the run directory)."""
    doc = load_tree(tree_path)
    clear_blackboard()
    design = doc.design
    if resume:
        run_dir = _resume_dir(runs_dir, resume, doc.name)
        design = DesignModel.load(run_dir / "asbuilt.json")
    else:
        run_dir = new_run_dir(runs_dir, doc.name)
    bridge = (DesignBridge(design, run_dir / "asbuilt.json", run_dir / "events.jsonl")
              if design is not None else None)
    # The simulated world is built from the original design: what is already placed stands.
    scene_args = (doc.design or design).scene_args() if design is not None else {}
    the_cell = load_cell(cell, doc.tick_hz, doc.scene, scene_args, seed=seed, perception=perception)
    if resume and the_cell.world is not None and design is not None:
        _stand_placed(the_cell.world, design)
    built = build(doc)
    if bridge:
        bridge.event("start", tree=str(tree_path), cell=cell, seed=seed, resume=bool(resume))
    runner = Runner(built, the_cell, run_dir, bridge, realtime=realtime,
                    progress=None if quiet else stderr_progress, estop_at=estop_at, max_time=max_time)
    try:
        runner.setup()
        with _frozen_heap():
            result = runner.run()
    finally:
        the_cell.close()
    if not quiet:
        end_stderr_progress()
    summary = summarize(result, the_cell, bridge.model if bridge else None)
    summary["run_dir"] = str(run_dir)
    if plots:
        png = plot_profiles(result.profiles, summary, the_cell.world, run_dir / "load_profiles.png")
        summary["plot"] = str(png) if png else None
    write_summary(summary, run_dir)
    if bridge:
        bridge.event("end", status=result.status, where=result.where, message=result.message)
    if not quiet:
        print(format_summary(summary))
        print(f"  run directory: {run_dir}" + (f" (chart: {summary.get('plot')})" if summary.get("plot") else ""))
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


def _stand_placed(world, design: DesignModel) -> None:
    """On resume in simulation, put already-placed elements where the as-built model says."""
    import numpy as np

    for eid in design.build_order():
        if design.is_placed(eid) and eid in world.elements:
            e = world.elements[eid]
            e.pose = np.array(design.graph.nodes[eid]["asbuilt_pose"], float)
            e.state = "standing"
