"""The tick loop of a run, on py_trees' `BehaviourTree`.

Every tick: the stop policy latches e-stop inputs, the perception stage publishes
/fv/left, /fv/right, /robot/*, /gripper/* and /task/estop, and the cell supervisor (when the run
is supervised) trips arm and gripper on any fault (pre-tick handlers); the tree ticks once; the
arm's watchdog is kicked, then the tip, the load profiles, the transition log and the progress
line are updated and a live monitor (`--groot2`) publishes the statuses (post-tick handlers); the
cell advances one period of its clock (simulated time, or a sleep to the next period on a real
cell). After the tick the stop policy may halt the run. A monitor's breakpoint may pause the tree
inside a tick: the cell does not step, and the stop policy's checks go on meanwhile (`Runner._hold`).

The loop is fail-safe: an exception anywhere in a tick (a skill, a handler, the cell) halts the
tree, stops arm and gripper and ends the run with status CRASHED, naming the node that raised;
an as-built record that cannot be written (`RecordNotWritten`: a full disk) ends it with status
FAULT the same way. The transition log and the recording degrade instead (`RunStorage`).
"""

from __future__ import annotations

import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import py_trees
from py_trees.common import Status

from assembly.design.bridge import DesignBridge
from assembly.language.build import BuiltTree
from assembly.outcome.result import RunResult
from assembly.run.events import EventSink
from assembly.run.load_profiles import LoadProfiles
from assembly.run.perception_stage import PerceptionStage
from assembly.run.progress import Progress
from assembly.run.stop_policy import Stop, StopPolicy
from assembly.run.storage import RunStorage
from assembly.run.supervisor import Supervision, Supervisor
from assembly.run.tip import Tip
from assembly.run.transitions import TransitionLog, element_in_work
from drivers.cell import Cell
from drivers.protocols import PerceptionSource
from fvfiles.errors import RecordNotWritten


class BehaviourTree(py_trees.trees.BehaviourTree):
    """py_trees' BehaviourTree; when it has no visitors, the root ticks without generators
    (`tick_once`, `assembly.nodes.composites`) and no walk over every node for the visitors follows."""

    def tick(self, pre_tick_handler: Callable | None = None, post_tick_handler: Callable | None = None) -> None:
        if self.visitors:
            super().tick(pre_tick_handler, post_tick_handler)
            return
        if pre_tick_handler is not None:
            pre_tick_handler(self)
        for handler in self.pre_tick_handlers:
            handler(self)
        self.root.tick_once()
        for handler in self.post_tick_handlers:
            handler(self)
        if post_tick_handler is not None:
            post_tick_handler(self)
        self.count += 1


class Recorder(Protocol):
    """A post-tick handler recording the run (`assembly.observe.recorder.RunRecorder`)."""

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None: ...

    def record(self, tick: int) -> None: ...

    def event(self, kind: str, **data) -> None: ...

    def close(self) -> None: ...


class Monitor(Protocol):
    """A live monitor of the run (`assembly.interop.groot2`, `fvtree run --groot2`): a post-tick
    handler publishing the statuses, which may pause the tree inside a tick at a breakpoint. While
    paused it calls the `hold` it was bound to every few milliseconds with the path of the node it
    waits at; `hold` raises to stop the run."""

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None: ...

    def bind(self, hold: Callable[[str], None]) -> None: ...

    @property
    def paused_s(self) -> float: ...

    def close(self) -> None: ...


class StoppedWhilePaused(Exception):
    """A stop (an e-stop, a fault) that came while a monitor held the tree paused mid-tick."""

    def __init__(self, stop: Stop):
        super().__init__(stop.message)
        self.stop = stop


class Runner:
    """Runs a built tree on a cell, tick by tick; call `setup()` before the first tick.

    With a run directory it writes the transition log there and stops when an `ESTOP` file
    appears in it; `progress` receives a line each time the tree's tip moves. With `supervision`
    the cell supervisor watches the cell every tick (`fvtree run` always supervises; the test
    harness, whose perception is scripted, does not). A `monitor` hears of every tick last, and
    may pause the tree inside a tick (a breakpoint): the cell does not step meanwhile, and `hold`
    keeps checking the e-stop inputs and the supervisor, stopping the run as after a tick.
    """

    def __init__(self, tree: BuiltTree, cell: Cell, run_dir: Path | None = None,
                 bridge: DesignBridge | None = None, realtime: bool = False,
                 progress: Callable[[str], None] | None = None,
                 sense: PerceptionSource | None = None,
                 estop_at: float | None = None, max_time: float = 3600.0,
                 supervision: Supervision | None = None, recorder: Recorder | None = None,
                 storage: RunStorage | None = None, monitor: Monitor | None = None,
                 events: EventSink | None = None):
        self.tree = tree
        self.cell = cell
        self.bridge = bridge
        self.events = events if events is not None else bridge  # the event log (a design run's: the bridge)
        self.realtime = realtime
        self.behaviour_tree = BehaviourTree(tree.root)
        self.tip = Tip(tree)
        self.stop_policy = StopPolicy(cell, self.tip, bridge, run_dir / "ESTOP" if run_dir else None,
                                      estop_at, max_time, self.events)
        self.perception = PerceptionStage(cell, sense)
        self.supervisor = Supervisor(cell, supervision, tree, self.tip) if supervision else None
        self.load_profiles = LoadProfiles()
        self.storage = storage or RunStorage(None)
        self.log = TransitionLog(tree, cell.clock, run_dir / "transitions.jsonl",
                                 lambda exc, since: self.storage.lost("transitions.jsonl", exc, since)) if run_dir else None
        self.progress = Progress(self.tip, cell.clock, progress) if progress else None
        self.recorder = recorder
        self.behaviour_tree.add_pre_tick_handler(self.stop_policy.before_tick)
        self.behaviour_tree.add_pre_tick_handler(self.perception)
        if self.log is not None:
            self.behaviour_tree.add_pre_tick_handler(self.log.before_tick)
        if self.supervisor is not None:
            self.behaviour_tree.add_pre_tick_handler(self.supervisor)
            self.stop_policy.checks.insert(0, self.supervisor.check)
        if self.events is not None:  # events stamped like the transitions: the run's tick, cell time, element
            self.events.stamp = self.stamp
        self.monitor = monitor
        for handler in (self._kick_watchdog, self.tip, self.load_profiles, self.log, self.recorder, self.progress,
                        monitor):
            if handler is not None:
                self.behaviour_tree.add_post_tick_handler(handler)
        if monitor is not None:
            monitor.bind(self._hold)
        self._set_up = False

    def stamp(self) -> dict:
        """The run's tick (going on from earlier sessions' in the transition log), cell time and
        element in work, for the event log's records."""
        base = self.log.tick_base if self.log is not None else 0
        return {"tick": base + self.behaviour_tree.count, "t": round(self.cell.clock.now(), 6),
                "element": element_in_work()}

    def setup(self) -> None:
        """Set up every node with the cell, the design model and the design bridge."""
        design = self.tree.document.design if self.bridge is None else self.bridge.model
        self.behaviour_tree.setup(cell=self.cell, design=design, bridge=self.bridge)
        if self.supervisor is not None and not self.cell.simulated:
            self.supervisor.await_fresh_perception(self.perception.sense)
        self._set_up = True

    @property
    def ticks(self) -> int:
        """Ticks done so far (during a tick: the number of this tick, from 0)."""
        return self.behaviour_tree.count

    # ---- one tick --------------------------------------------------------------------------
    def tick(self) -> Status:
        self.behaviour_tree.tick()
        self.cell.step()
        return self.behaviour_tree.root.status

    def _kick_watchdog(self, tree: py_trees.trees.BehaviourTree) -> None:
        self.cell.arm.kick()

    def _hold(self, where: str) -> None:
        """While a monitor pauses the tree mid-tick at the node `where` (the cell does not step): the
        e-stop inputs and the supervisor are checked as before a tick, and a stop due ends the run."""
        self.tip.path = where  # where the tree is: what a stop now interrupts
        self.stop_policy.before_tick(self.behaviour_tree)
        if self.supervisor is not None:
            self.supervisor(self.behaviour_tree)
        stop = self.stop_policy.check()
        if stop is not None:
            raise StoppedWhilePaused(stop)

    # ---- the loop --------------------------------------------------------------------------
    def run(self) -> RunResult:
        """Tick until the root succeeds or fails, or the stop policy or Ctrl-C stops the run."""
        if not self._set_up:
            raise RuntimeError("Runner.run() before Runner.setup()")
        start = time.perf_counter()
        try:
            while True:
                status = self.tick()
                stop = self.stop_policy.check()
                if stop is not None:
                    return self._stopped(stop, start)
                if status != Status.RUNNING:
                    break
                if self.realtime and self.cell.simulated:
                    self._pace(start)
        except KeyboardInterrupt as interrupt:
            return self._stopped(self.stop_policy.interrupted(interrupt), start)
        except StoppedWhilePaused as paused:
            return self._stopped(paused.stop, start)
        except RecordNotWritten as exc:  # the record of what stands is not kept: stop the cell
            where = self._raiser(exc) or self.tip.path
            return self._stopped(Stop("FAULT", f"{exc} (in {where})", where), start)
        except Exception as exc:  # noqa: BLE001 - the fail-safe: whatever raised, the cell stops
            return self._crashed(exc, start)
        finally:
            if self.log:
                self.log.close()
            if self.recorder:
                self.recorder.close()
        where, message = self.tip.path, ""
        if status == Status.FAILURE:
            where, message = self._failure()
        return self._result(status.name, start, where, message)

    def _pace(self, start: float) -> None:
        paused = self.monitor.paused_s if self.monitor is not None else 0.0
        ahead = self.cell.clock.now() - (time.perf_counter() - start - paused)
        if ahead > 0:
            time.sleep(ahead)

    def halt(self, where: str | None = None, event: str = "halted", **data) -> None:
        """Stop the tree (every running skill's terminate runs), the arm and the gripper; the
        run's event log (if any) takes `event` at `where` (default: the tip) with `data`."""
        self.tip(self.behaviour_tree)
        self.stop_policy.halt(self.behaviour_tree.root, where or self.tip.path, event, **data)
        if self.log:
            self.log.record(self.ticks)
        if self.monitor is not None:
            self.monitor(self.behaviour_tree)
        if self.recorder:
            if self.events is None:  # no event log for the recorder to read: tell it
                self.recorder.event(event, where=where or self.tip.path, **data)
            self.recorder.record(self.ticks)
        self.come_to_rest()  # after the records: they keep one tick a period

    def come_to_rest(self, limit: float = 2.0) -> None:
        """On a simulated cell, let the world run on (without ticking the tree) until the arm and the
        gripper are at rest, at most `limit` s of cell time: a stopped arm brakes over its latency and
        deceleration, as a UR does (`drivers/sim/devices/arm_motion.py`), and the run ends once it
        stands. A real cell's devices brake on their own time."""
        if not self.cell.simulated:
            return
        for _ in range(round(limit / self.cell.clock.period)):
            if not (self.cell.arm.is_moving() or self.cell.gripper.is_moving()):
                return
            self.cell.arm.kick()  # the runner is alive: only the tree is not ticked
            self.cell.step()

    def _stopped(self, stop: Stop, start: float) -> RunResult:
        where = stop.where or self.tip.path
        self.halt(where, status=stop.status, message=stop.message)
        return self._result(stop.status, start, where, stop.message)

    def _crashed(self, exc: Exception, start: float) -> RunResult:
        where = self._raiser(exc) or self.tip.path
        message = f"{type(exc).__name__}: {exc} (in {where})"
        trace = "".join(traceback.format_exception(exc))
        self.halt(where, "crashed", message=message, traceback=trace)
        result = self._result("CRASHED", start, where, message)
        result.traceback = trace
        return result

    def _raiser(self, exc: Exception) -> str | None:
        """The path of the deepest node of this tree on the exception's stack, if any."""
        paths = {id(node): path for path, node in self.tree.nodes.items()}
        found, frame = None, exc.__traceback__
        while frame is not None:
            found = paths.get(id(frame.tb_frame.f_locals.get("self")), found)
            frame = frame.tb_next
        return found

    def _failure(self) -> tuple[str, str]:
        """The path and feedback of the deepest failed node: where and why the tree failed."""
        failed = [(p, n) for p, n in self.tree.nodes.items()
                  if n.status == Status.FAILURE and n.feedback_message]
        if not failed:
            return self.tip.path, ""
        path, node = max(failed, key=lambda pn: pn[0].count("/"))
        return path, node.feedback_message

    def _result(self, status: str, start: float, where: str, message: str) -> RunResult:
        return RunResult(status, self.ticks, self.cell.clock.now(), time.perf_counter() - start,
                         where, message, self.load_profiles.profiles,
                         margins=self.supervisor.margins.report() if self.supervisor is not None else {})
