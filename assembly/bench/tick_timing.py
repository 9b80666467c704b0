"""Timing a run of trees/assembly.yaml as `fvtree run` runs it, for the tick benchmarks
(`assembly.bench.ticks`, `speed_accuracy`, `tick_costs`): each part of every tick (`TickTimes`), and
whole runs with their CPU time, result and summary (`assembly_run`)."""

from __future__ import annotations

import os
import tempfile
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

from py_trees.blackboard import Blackboard

from assembly.language.reader import TreeDocument
from assembly.outcome.result import RunResult
from assembly.outcome.summary import Summary
from assembly.run.loop import Runner
from assembly.run.options import RunOptions
from assembly.run.session import Run
from behaviours.skill_kit import keys
from drivers.cell import Cell
from perception.state import TactileState

TREE = Path(__file__).resolve().parents[2] / "trees" / "assembly.yaml"


class TickTimes:
    """How long each part of every tick of a runner takes (seconds): each pre- and post-tick handler
    (named as `stage_name` says), the tree tick between them, the cell step and the whole tick, and
    each leaf behaviour's own `update`. Wraps the runner's handlers, leaves and `tick` in place."""

    def __init__(self, runner: Runner):
        self.runner = runner
        self._last_mark = 0.0
        self.parts: dict[str, list[float]] = defaultdict(list)
        self.behaviour_times: dict[str, list[float]] = defaultdict(list)
        for path, node in runner.tree.nodes.items():
            if not node.children:  # leaves: skills and conditions
                node.update = timed(node.update, self.behaviour_times[path])  # type: ignore[method-assign]
        tree = runner.behaviour_tree
        # Parts in tick order: the marks time the tree tick (between the pre- and post-tick
        # handlers) and the cell step (after the post-tick handlers).
        pre = [timed(h, self.parts[self.stage_name(h)]) for h in tree.pre_tick_handlers]
        tree_tick = self.parts["tree tick"]
        post = [timed(h, self.parts[self.stage_name(h)]) for h in tree.post_tick_handlers]
        self._cell_step, self._whole_tick = self.parts["cell step"], self.parts["whole tick"]
        tree.pre_tick_handlers[:] = [*pre, self._mark]
        tree.post_tick_handlers[:] = [lambda _: tree_tick.append(time.perf_counter() - self._last_mark),
                                      *post, self._mark]
        self._tick = runner.tick
        runner.tick = self._timed_tick  # type: ignore[method-assign]  # the loop calls the instance's tick

    def stage_name(self, handler) -> str:
        """A tick handler's stage: the runner's attribute holding it or the object it is a method
        of ("recorder", "stop policy"), its own name for a method of the runner ("kick watchdog"),
        else its class; unique (a second handler of one name gets " 2")."""
        owner = getattr(handler, "__self__", None)
        if owner is self.runner:
            name = handler.__name__
        else:
            name = next((attr for attr, value in vars(self.runner).items()
                         if value is handler or (owner is not None and value is owner)), type(handler).__name__)
        name = name.strip("_").replace("_", " ")
        n = 1
        while (f"{name} {n}" if n > 1 else name) in self.parts:
            n += 1
        return f"{name} {n}" if n > 1 else name

    def _mark(self, tree) -> None:
        self._last_mark = time.perf_counter()

    def _timed_tick(self):
        start = time.perf_counter()
        status = self._tick()
        end = time.perf_counter()
        self._cell_step.append(end - self._last_mark)
        self._whole_tick.append(end - start)
        return status


def timed(function, sink: list[float]):
    """`function`, appending the seconds each call takes to `sink`."""
    clock = time.perf_counter

    def timed_call(*args, **kwargs):
        t0 = clock()
        result = function(*args, **kwargs)
        sink.append(clock() - t0)
        return result
    return timed_call


@dataclass
class AssemblyRun:
    """One run of the assembly: its tree document, tick times (when timed), result, summary (judged
    against the scene's truth), cell and the CPU seconds it took (pixel-mode workers included)."""

    doc: TreeDocument
    times: TickTimes | None
    result: RunResult
    summary: Summary
    cell: Cell
    cpu: float
    states: dict[str, TactileState] = field(default_factory=dict)  # the fingertips' last states, by finger

    @property
    def cpu_per_tick(self) -> float:
        """CPU seconds per tick."""
        return self.cpu / max(self.result.ticks, 1)

    @property
    def cpu_factor(self) -> float:
        """Simulated seconds per CPU second: the real-time factor a quiet machine would show."""
        return self.result.sim_time / max(self.cpu, 1e-9)


def assembly_run(timed: bool, seed: int, cell_file: str = "sim", perception: str | None = None,
                 max_time: float = 3600.0, groot2: tuple[str, int] | None = None,
                 tree: Path = TREE) -> AssemblyRun:
    """One assembly run as `fvtree run` runs it (supervised, recorded with camera frames at the
    default rate, a run directory with its design bridge, transition log and event log, heap
    frozen; no progress line), timed tick by tick when `timed`; `groot2`: served to Groot2 on
    (address, port). On a shared machine other processes add wall time but not CPU time."""
    with tempfile.TemporaryDirectory() as tmp:
        options = RunOptions(cell=cell_file, seed=seed, perception=perception, max_time=max_time,
                             runs_dir=Path(tmp), plots=False, quiet=True, groot2=groot2)
        with Run(tree, options) as run:
            times = TickTimes(run.runner) if timed else None
            cpu = time.process_time()
            result = run.loop()
            cpu = time.process_time() - cpu + _workers_cpu(run.cell)
            states = {s.finger: s for s in (Blackboard.storage.get(key) for key in (keys.FV_LEFT, keys.FV_RIGHT))
                      if isinstance(s, TactileState)}
            summary = run.finish(result)  # the event log's end goes in and the recording's file is complete
    return AssemblyRun(run.doc, times, result, summary, run.cell, cpu, states)


def _workers_cpu(cell) -> float:
    """CPU seconds the cell's perception worker processes have used (pixel mode's fingers in
    parallel; 0 without workers), read before the cell closes them."""
    total = 0.0
    for process in getattr(cell.sense, "processes", {}).values():
        try:
            fields = Path(f"/proc/{process.pid}/stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime
    return total
