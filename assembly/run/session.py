"""One run of a tree on a cell, held as an object: `Run(tree, RunOptions(...))` loads and
validates the tree, sets up the run directory and the design bridge (resuming a previous run if
asked), builds the cell, the py_trees tree, the recorder and the tick loop; `tick()` ticks it
once, `run()` to the end, which judges it and returns its `Summary`. The command line, the
benchmarks, the dataset recorder and the test harness all run trees this way.

The cell is closed whatever happens once it is built (`close()`, or leaving a `with Run(...)`
block), and SIGTERM halts `run_tree` like Ctrl-C from its start."""

from __future__ import annotations

import gc
import json
import sys
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np
from py_trees.common import Status

from assembly.design.bridge import DesignBridge
from assembly.design.model import DesignModel
from assembly.errors import TreeError
from assembly.language.build import BuiltTree, build
from assembly.language.reader import TreeDocument, load_tree, with_scene
from assembly.language.substitution import substitute
from assembly.observe.recorder import recording_path, run_recorder
from assembly.outcome.charts import plot_profiles
from assembly.outcome.result import RunResult
from assembly.outcome.summary import SUMMARY_FILE, Summary, format_summary, summarize
from assembly.outcome.verdict import TASK_FAILED, judge, tolerances_for
from assembly.run.event_log import Box, cell_box, check_run_records, drop_torn_tail
from assembly.run.events import EventSink
from assembly.run.loop import Monitor, Runner
from assembly.run.options import MARKS, RunOptions
from assembly.run.perception_stage import clear_blackboard
from assembly.run.progress import end_stderr_progress, stderr_progress
from assembly.run.recording_guard import GuardedRecorder, guarded_recorder
from assembly.run.run_dir import ASBUILT_FILE, EVENTS_FILE, find_run, new_run_dir, write_run_file
from assembly.run.run_lock import RunLock
from assembly.run.storage import RunStorage, storage_errors_located, why
from assembly.run.supervisor import Supervision
from assembly.signals import sigterm_raises_terminated
from drivers.cell import Cell
from drivers.cell_builders import load_cell
from drivers.protocols import World
from fvfiles.errors import FvtreeError
from fvfiles.json_files import EventLog, read_json_lines

if TYPE_CHECKING:
    from typing_extensions import Self  # typing.Self from Python 3.11

Sense = Callable[[Cell], Mapping[str, Any]]  # this tick's perception of a cell (default: `cell.sense()`)


class Run:
    """One run of `tree` (a tree file, or a validated document) with `options`.

    `cell` runs it on a cell built by the caller (a test harness's mocked cell) instead of the one
    `options.cell` names; `sense` replaces each tick's perception (scripted states, or the cell's
    own recorded beside something else). Open it (`open()`, or `with Run(...) as run:`) before
    ticking it."""

    def __init__(self, tree: str | Path | TreeDocument, options: RunOptions | None = None, *,
                 cell: Cell | None = None, sense: Sense | None = None):
        self.options = options or RunOptions()
        self.doc, self.substituted = self._document(tree)  # a tree file is read and checked whole here
        self._check_options()
        self.given_cell = cell
        self.sense = sense
        self.run_dir: Path | None = None
        self.bridge: DesignBridge | None = None
        self.events: EventSink | None = None  # the run directory's event log: the bridge, or an `EventLog`
        self.tolerances: dict[str, float] = {}
        self.nothing_to_do: Summary | None = None  # a resumed run with every element placed
        self._parts: _Parts | None = None
        self._before: dict = {}  # the summary an earlier session of a resumed run wrote
        self._placed_before: list[str] = []
        self._unstood: list[str] = []  # notes on elements placed before a resume the world could not stand
        self._cell_closed = False
        self._finished = False
        self._lock: RunLock | None = None  # the run directory's, held from its choice to `close()`
        self.storage = RunStorage(None)  # what disk trouble cost the run (with a run directory: its reserve)

    @property
    def cell(self) -> Cell:
        return self._opened().cell

    @property
    def tree(self) -> BuiltTree:
        return self._opened().tree

    @property
    def runner(self) -> Runner:
        return self._opened().runner

    @property
    def recorder(self) -> GuardedRecorder | None:
        return self._parts.recorder if self._parts is not None else None

    # ---- opening ---------------------------------------------------------------------------
    def __enter__(self) -> Self:
        self.open()
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.close()

    def open(self) -> Run:
        """Prepare the run directory and design bridge, build the cell, the tree, the recorder and
        the tick loop, and set every node up. A cell built here is closed again if a later step
        fails."""
        clear_blackboard()
        try:
            if not self._prepare_run_dir():
                return self
        except BaseException:
            self.close()  # frees the run directory's lock, if it was taken
            raise
        design = self.design
        self._placed_before = [e for e in design.build_order() if design.is_placed(e)] if design else []
        cell = self.given_cell or self._load_cell()
        try:
            self._parts = self._build(cell)
            self.runner.setup()
        except BaseException:
            self._cell_closed = True
            cell.close()
            self.close()
            raise
        return self

    def _document(self, tree: str | Path | TreeDocument) -> tuple[TreeDocument, list[dict]]:
        """The validated tree with the options' scene and test doubles, and the doubles put in."""
        doc = tree if isinstance(tree, TreeDocument) else load_tree(tree, cell=self.options.cell)
        if self.options.scene is not None:
            doc = with_scene(doc, self.options.scene)
        return substitute(doc, list(self.options.substitutions))

    def _check_options(self) -> None:
        """Options that only make sense together, checked before anything is created."""
        o = self.options
        if o.marks and not o.resume:
            raise TreeError("--mark records a check of a stopped run: use it with --resume", self.doc.path)
        if (o.resume or o.link) and o.runs_dir is None:
            raise TreeError("resuming and the design link need a run directory", self.doc.path)
        for eid, status in o.marks.items():
            if status not in MARKS:
                raise TreeError(f"--mark {eid}={status}: mark an element {' or '.join(MARKS)}", self.doc.path)

    def _prepare_run_dir(self) -> bool:
        """The run directory and the design bridge (a new run, or the run to resume, caught up);
        False when a resumed run has nothing left to do."""
        o, doc = self.options, self.doc
        if o.runs_dir is None:
            return True
        with storage_errors_located(o.runs_dir):
            if o.resume:
                self.run_dir = find_run(o.runs_dir, o.resume, doc)
                self._lock = RunLock(self.run_dir).acquire()  # before anything is read: no second session
                self._before = _previous_summary(self.run_dir)
                self.bridge = _resumed_bridge(self.run_dir, doc, dict(o.marks), cell_box(o.cell))
                if self.bridge is None:
                    self.nothing_to_do = Summary.from_json({**self._before, "run_dir": str(self.run_dir),
                                                            "nothing_to_do": True})
                    return False
            else:
                self.run_dir = new_run_dir(o.runs_dir, doc.name)
                self._lock = RunLock(self.run_dir).acquire()  # before run.json makes it a run to resume
                write_run_file(self.run_dir, doc, cell=o.cell, seed=o.seed)
                if doc.design is not None:
                    self.bridge = DesignBridge(doc.design, self.run_dir / ASBUILT_FILE, self.run_dir / EVENTS_FILE)
        self.storage = RunStorage(self.run_dir)
        self.events = self.bridge if self.bridge is not None else EventLog(self.run_dir / EVENTS_FILE)
        if self.bridge is not None and o.link is not None:
            from assembly.design.link.mqtt_bridge import attach_options  # compas_eve and paho: only when linked

            attach_options(self.bridge, o.link, o.link.cell_name or doc.name, o.cell)
        return True

    @property
    def design(self) -> DesignModel | None:
        """The design model the run builds: the bridge's (as-built so far), else the tree's."""
        return self.bridge.model if self.bridge is not None else self.doc.design

    def _load_cell(self) -> Cell:
        o, doc = self.options, self.doc
        # The simulated world is built from the original design: what is already placed stands.
        scene_args = {**(doc.design.scene_args() if doc.design is not None else {}), **o.scene_args}
        return load_cell(o.cell, doc.tick_hz, doc.scene, scene_args, seed=o.seed, perception=o.perception)

    def _build(self, cell: Cell) -> _Parts:
        o = self.options
        supervision = Supervision.of_cell(o.cell) if o.supervised else None
        design = self.design
        if cell.world is not None:
            self.tolerances = tolerances_for(self.doc, cell.world)
            if design is not None:  # on resume in simulation, what is placed already stands
                self._unstood = _stand_placed(cell.world, design, self._placed_before)
        tree = build(self.doc)
        recorder = None  # the recording and its live view follow the run directory's event log
        if self.run_dir is not None and (o.record or o.live):
            run_dir = self.run_dir
            recorder = guarded_recorder(self.storage, recording_path(run_dir) if o.record else None,
                                        lambda: run_recorder(tree, cell, run_dir, design, o.record, o.live,
                                                             o.record_images))
        sense, given = None, self.sense
        if given is not None:
            def sense() -> Mapping[str, Any]:
                return given(cell)
        monitor = self._monitor(tree, cell)
        runner = Runner(tree, cell, self.run_dir, self.bridge, realtime=o.realtime,
                        progress=None if o.quiet else stderr_progress, sense=sense, estop_at=o.estop_at,
                        max_time=o.max_time, supervision=supervision, recorder=recorder, storage=self.storage,
                        monitor=monitor, events=self.events)
        if self.events is not None:  # every run's log begins so, with or without a design
            self.events.event("start", tree=str(self.doc.path), cell=o.cell, seed=o.seed, resume=bool(o.resume))
        return _Parts(cell, tree, recorder, runner, monitor)

    def _monitor(self, tree: BuiltTree, cell: Cell) -> Monitor | None:
        """The Groot2 server the options ask for; breakpoints only where the world waits for the tree."""
        if self.options.groot2 is None:
            return None
        from assembly.interop.groot2 import start_monitor  # pyzmq and msgpack: only with --groot2

        host, port = self.options.groot2
        refused = None if cell.simulated else (
            "breakpoints are refused on a real or emulated cell: its motions go on while the tree waits; "
            "use them on the simulated cell")
        return start_monitor(self.doc, tree.nodes, cell.clock.now, port, host, refused)

    # ---- running ---------------------------------------------------------------------------
    @property
    def ticks(self) -> int:
        """Ticks done so far."""
        return self._parts.runner.ticks if self._parts is not None else 0

    def tick(self) -> Status:
        """One tick of the tree and one period of the cell; the root's status."""
        return self.runner.tick()

    def halt(self) -> None:
        """What Ctrl-C does: stop every running node, the arm and the gripper."""
        self.runner.halt()

    def loop(self) -> RunResult:
        """Tick until the tree ends or the run is stopped (the runner's fail-safe loop), with the
        heap frozen out of the garbage collector's view."""
        runner = self.runner
        with _frozen_heap():
            return runner.run()

    def finish(self, result: RunResult) -> Summary:
        """Close the cell, then summarize the run, judge it by the scene's truth, write the chart
        and `summary.json`, log its end and, unless quiet, print the summary."""
        self.close_cell()
        self._finished = True
        o, cell = self.options, self.cell
        if not o.quiet:
            end_stderr_progress()
        kept = self._before.get("elements", {})
        # Elements judged placed by an earlier session keep its figures; an element placed by a
        # person's mark since is judged now, standing at its as-built pose in the world.
        summary = summarize(result, cell, self.design, {e: kept[e] for e in self._placed_before
                                                        if kept.get(e, {}).get("status") == "placed"})
        summary.run_dir = None if self.run_dir is None else str(self.run_dir)
        summary.substitutions = self.substituted
        if cell.world is not None:
            summary.apply(judge(cell.world, self.tolerances, self._unstood))
        self._log_end(summary, result)  # first: the event log's end matters more than the files below
        if self.run_dir is not None:
            self._write(summary, result, self.run_dir)
        if not o.quiet:
            self._print(summary)
        return summary

    def run(self) -> Summary:
        """Run to the end and summarize (a resumed run with nothing left: the earlier summary)."""
        if self.nothing_to_do is not None:
            if not self.options.quiet:
                print(_nothing_to_do_line(self.nothing_to_do))
            return self.nothing_to_do
        return self.finish(self.loop())

    def _opened(self) -> _Parts:
        if self._parts is None:
            raise RuntimeError("open the Run before ticking it" if self.nothing_to_do is None
                               else "a resumed run with every element placed has nothing to tick")
        return self._parts

    # ---- after the last tick -----------------------------------------------------------------
    def _write(self, summary: Summary, result: RunResult, run_dir: Path) -> None:
        """Chart and summary file, with what disk trouble lost (`Summary.lost`); a run directory that
        cannot be written loses them, not the run (the summary is still printed)."""
        if self.options.plots:
            try:
                png = plot_profiles(result.profiles, self.cell.world, run_dir / "load_profiles.png")
                summary.plot = str(png) if png else None
            except OSError as exc:
                self.storage.lost("load_profiles.png", exc)
        self.storage.release()  # the run's records are written: the reserve's room is the summary's
        summary.lost = self._lost()
        try:
            summary.write(run_dir)
        except OSError as exc:
            self.storage.lost(SUMMARY_FILE, exc)
            summary.lost = self._lost()
            print(f"cannot write the summary to {self.run_dir} ({why(exc)})", file=sys.stderr)

    def _lost(self) -> list[str]:
        """What disk trouble cost this run: the storage's notes and events that only reached stderr."""
        unlogged = self.events.unlogged if self.events is not None else 0
        return self.storage.notes + ([f"{EVENTS_FILE}: {unlogged} records only on stderr"] if unlogged else [])

    def _log_end(self, summary: Summary, result: RunResult) -> None:
        end = {"status": summary.status, "where": result.where, "message": summary.message}
        if self.events is not None:
            self.events.event("end", **end)
        elif self.recorder is not None:  # no event log for the recorder to read the end from: tell it
            self.recorder.event("end", **end)
        if self.bridge is not None:
            self.bridge.close()
        if self.recorder is not None:
            self.recorder.finish()

    def _print(self, summary: Summary) -> None:
        print(format_summary(summary))
        for made in summary.substitutions:
            print(f"  substituted: {made['path']} ({made['was']}) by {made['double']}")
        if summary.run_dir:
            print(f"  run directory: {summary.run_dir}" + (f" (chart: {summary.plot})" if summary.plot else ""))

    # ---- closing ---------------------------------------------------------------------------
    def close_cell(self) -> None:
        """Stop and close the cell (its devices, simulator workers, cameras), once."""
        if self._parts is not None and not self._cell_closed:
            self._cell_closed = True
            self._parts.cell.close()

    def close(self) -> None:
        """Close the cell and, for a run left unfinished, the design bridge's links and the recorder;
        then stop the Groot2 server and free the run directory for another session."""
        try:
            if self._parts is not None and self._parts.monitor is not None:
                self._parts.monitor.close()
            self.close_cell()
            if not self._finished:
                self._finished = True
                if self.bridge is not None:
                    self.bridge.close()
                if self.recorder is not None:
                    self.recorder.finish()
        finally:
            self.storage.release()
            if self._lock is not None:
                self._lock.release()


def world_of(cell: Cell) -> World:
    """The simulated scene of `cell`; what asks for it (labels, truth, metrics) needs a simulated cell."""
    if cell.world is None:
        raise FvtreeError(f"cell {cell.name!r} simulates no scene, and this needs one", hint="use --cell sim")
    return cell.world


@dataclass(frozen=True)
class _Parts:
    """What an opened run is made of."""

    cell: Cell
    tree: BuiltTree
    recorder: GuardedRecorder | None
    runner: Runner
    monitor: Monitor | None = None


@sigterm_raises_terminated()  # from the start: SIGTERM while the cell is set up closes it like Ctrl-C
def run_tree(tree: str | Path | TreeDocument, options: RunOptions | None = None) -> Summary:
    """Run a tree file (or a tree already read) end to end as `fvtree run` does; its summary (also
    in the run directory)."""
    with Run(tree, options) as run:
        return run.run()


def _previous_summary(run_dir: Path) -> dict:
    """The summary an earlier session of this run wrote, if any."""
    try:
        data = json.loads((run_dir / SUMMARY_FILE).read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _nothing_to_do_line(summary: Summary) -> str:
    return (f"nothing to do: every element of {summary.run_dir} is placed"
            + (f" (the run ended {summary.status})" if summary.status else ""))


def _resumed_bridge(run_dir: Path, doc: TreeDocument, marks: dict[str, str], box: Box) -> DesignBridge | None:
    """The design bridge of a run to resume, its records checked (`check_run_records`: in the cell's
    `box`, in the order a run writes them) and caught up with its event log and a person's marks;
    None when every element is placed and the last session ended with the tree done (a session
    stopped after the last placement resumes to finish the tree: the retreat, the way home). An
    element left `placing` stops the resume."""
    model = DesignModel.load(run_dir / ASBUILT_FILE)
    check_run_records(run_dir, model, box, EVENTS_FILE, ASBUILT_FILE)
    if torn := drop_torn_tail(run_dir / EVENTS_FILE):
        print(f"{run_dir / EVENTS_FILE}: cut off its last line, torn by a crash ({torn} bytes)", file=sys.stderr)
    bridge = DesignBridge(model, run_dir / ASBUILT_FILE, run_dir / EVENTS_FILE)
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
    if all(design.is_placed(e) for e in design.build_order()) and design.build_order() \
            and _last_session_ended(run_dir / EVENTS_FILE) in DONE:
        return None
    return bridge


def _stand_placed(world: World, design: DesignModel, placed: list[str]) -> list[str]:
    """Stand each element placed before a resume at its as-built pose in the simulated world, so its
    truth is judged with the rest; a note for each that has no pose to stand it at."""
    notes = []
    for eid in placed:
        pose = design.graph.nodes[eid].get("asbuilt_pose")
        if pose is None:
            notes.append(f"{eid}: marked placed with no as-built pose, so the scene could not stand it and its "
                         "placement was not judged")
        else:
            world.stand(eid, np.array(pose, float))
    return notes


DONE = ("SUCCESS", TASK_FAILED)  # a session that ended so ran its tree to the end: nothing is left to do


def _last_session_ended(events: Path) -> str | None:
    """The status the last session of a run ended with (its `end` record after its `start`), or
    None when it never logged its end (killed, or its log lost)."""
    ended = None
    for record in read_json_lines(events):
        if record.get("event") == "start":
            ended = None
        elif record.get("event") == "end":
            ended = record.get("status")
    return ended if isinstance(ended, str) else None


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
