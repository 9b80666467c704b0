"""`RunRecorder`: every run as a Rerun recording (`runs/<id>/recording.rrd`), written as the run
goes, and optionally streamed live to a viewer.

Timelines `tick` and `cell_time`, and `change` on the tree's status changes (`tree/status`,
`tree/transitions`): their number in the recording, 0, 1, ..., so that a query by it (Rerun's
dataframe API) reads every change, where a query by tick keeps one row per tick. Per tick (kept
in columns, sent once per batch): robot pose and wrench, gripper width and object flag, the tool's
3-D transform, and per finger the marker displacement arrows, force, torque, slip, object area/centroid/orientation and health. When they
change: node statuses (graph colours and a structured `tree/status` row with the feedback), the
marker origins and validity, the feedback of running nodes (`tree/feedback`: e.g. each sample of a
load scan), the element being built, the load profile, the events of the run (placements, faults,
halts, and its `end` with status and cause) with the placed elements in 3-D. Every command that
passes the safety gate of arm and gripper (`Guard.observers`). Each finger's camera frame as a JPEG under its marker
arrows (`fv/<finger>/markers/image`), `images_hz` times a second of cell time, when the perception
source has images (pixel mode, real cameras: `drivers.camera_frames`). A batch is sent every `batch`
ticks or `max_wait` s of wall time, whichever comes first, so a killed run keeps all but its last batch.
A tick writes references into the batch's column lists (`columns.TickColumns`); the drawings of a load
scan in progress and the camera frames go with the batch too (a column of JPEGs per finger and batch
costs the main process ~0.04 ms a frame, logging each frame on its own ~0.2-0.4 ms).
"""

from __future__ import annotations

import json
import os
import time
from itertools import compress
from operator import attrgetter, ne
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import rerun as rr
from py_trees.blackboard import Blackboard
from py_trees.common import Status

from assembly.design.model import DesignModel
from assembly.language.build import BuiltTree
from assembly.observe import IMAGE_HZ
from assembly.observe.columns import Sparse, TickColumns, column, scalars_column
from assembly.observe.layout import default_blueprint
from assembly.observe.scene3d import element_box, plate_boxes, quaternions
from assembly.observe.tree_graph import tree_graph
from behaviours.skill_kit import keys
from drivers.camera_frames import LatestFrames, frames_of
from drivers.cell import Cell
from perception.state import FINGERS

APPLICATION = "fvtree"
RECORDING_FILE = "recording.rrd"
# Scalar entities: their first column in `TickColumns.robot_table` and `finger_table`, and their names.
ROBOT = {"robot/pose": (0, ["x", "y", "z", "rx", "ry", "rz"]),
         "robot/wrench": (6, ["fx", "fy", "fz", "tx", "ty", "tz"]),
         "gripper/width": (12, ["width"]), "gripper/object": (13, ["object"])}
FINGER = {"force": (0, ["x", "y", "z"]), "torque": (3, ["x", "y", "z"]), "slip": (6, ["slip"]),
          "object": (7, ["area", "centroid x", "centroid y", "orientation"]),
          "health": (11, ["healthy", "valid markers", "object present"])}
VALID_RGBA, INVALID_RGBA = np.uint32(0x3CB44BFF), np.uint32(0xDC322FFF)  # tracked, lost markers (packed RGBA)
EVENT_LEVELS = {"crashed": "CRITICAL", "halted": "WARN", "failed": "WARN"}
END_LEVELS = {"SUCCESS": "INFO", "CRASHED": "CRITICAL"}  # the `end` event by the run's status (else WARN)
NODE_RADIUS = 14.0  # tree graph nodes, in the graph's units (nodes are X_STEP apart)
STATE = attrgetter("status", "feedback_message")
LOAD_RGB = (150, 150, 150)  # the load line of a profile
PROFILE_HEIGHT = 0.4  # the load profile is drawn this high for its span (a 2-D view keeps aspect)
SCAN_PERIOD = 1.0  # s of cell time between two drawings of a load scan in progress
JPEG_QUALITY = 85  # camera frames: about 13 kB each at 320x240, 0.15 ms to encode
CHANGE_TIMELINE = "change"  # tree statuses and transitions: the status change's number in the recording
IMAGES = {finger: f"fv/{finger}/markers/image" for finger in FINGERS}  # each finger's camera frames


class RunRecorder:
    """Post-tick handler recording a run (see the module docstring); `close()` sends what is left.

    `path`: the .rrd file (None: no file); `live`: a gRPC URL of a viewer to stream to (None: no
    live view). `events`: the run's event log, read as it grows. `images_hz`: camera frames a second
    of cell time, JPEG-encoded, when the perception source has images (0: none)."""

    def __init__(self, tree: BuiltTree, cell: Cell, path: Path | None = None, live: str | None = None,
                 design: DesignModel | None = None, events: Path | None = None, batch: int = 1000,
                 max_wait: float = 1.0, images_hz: float = IMAGE_HZ):
        self.cell = cell
        self._frames = frames_of(cell.sense) if images_hz > 0 else None
        self._image_period = 1.0 / images_hz if images_hz > 0 else float("inf")
        self._next_image = -float("inf")  # cell time of the next frame to record
        self.path = path
        self.batch, self.max_wait = batch, max_wait
        self.stream = rr.RecordingStream(APPLICATION, recording_id=f"{path.parent.name}/{path.stem}" if path else None)
        sinks = ([rr.FileSink(str(path))] if path else []) + ([rr.GrpcSink(live)] if live else [])
        self.stream.set_sinks(*sinks, default_blueprint=default_blueprint())
        self.stream.set_log_time_enabled(False)  # the run's own timelines only: replays are deterministic
        self.stream.set_log_tick_enabled(False)
        self._nodes = list(tree.nodes.items())
        self._paths = [path for path, _ in self._nodes]
        self._graph = tree_graph(tree.document.root)
        self._order = {p: i for i, p in enumerate(self._graph.paths)}
        self._statuses = ["INVALID"] * len(self._graph.paths)
        self._last = [Status.INVALID] * len(self._nodes)  # each node's last recorded status and feedback
        self._feedback = [""] * len(self._nodes)
        self._changes = 0  # status changes sent (the `change` timeline)
        self._columns = TickColumns(0)  # the batch's ticks (made at its first tick, for its calibrations)
        self._next_tick = 0  # the tick that commands sent now belong to
        self._sent_at = time.perf_counter()
        self._sparse = {name: Sparse() for name in ("status", "transitions", "feedback", "graph", "commands/arm",
                                                    "commands/gripper", *IMAGES.values())}
        self._node_objects = [node for _, node in self._nodes]
        self._seen: list[tuple] = []  # every node's (status, feedback) at the last tick
        self._origins: dict[str, np.ndarray | None] = {f: None for f in FINGERS}
        self._origins_logged = False  # new origins logged since the last batch (to be written before its arrows)
        self._element = self._profile = self._scan = None
        self._element_id = "element"  # the id of the element being built, naming its load profile
        self._next_scan, self._scan_drawn = 0.0, 0  # cell time of the next drawing of the scan, samples drawn
        self._design = design
        self._events = events
        self._events_fd: int | None = None  # the event log, opened once it exists
        self._events_read = 0  # bytes of the event log recorded
        self._closed = self._finished = False
        self._static(tree)
        for guard in (cell.arm, cell.gripper):
            if hasattr(guard, "observers"):
                guard.observers.append(self.command)

    # ---- what never changes --------------------------------------------------------------------
    def _static(self, tree: BuiltTree) -> None:
        log = self.stream.log
        g = self._graph
        # Colours only on the timelines: static values would hide every later change of them.
        log("tree/graph", rr.GraphNodes(g.paths, labels=g.labels, positions=g.positions, radii=NODE_RADIUS,
                                        show_labels=True), static=True)
        self._sparse["graph"].add(0, self.cell.clock.now(), g.colours(self._statuses))
        log("tree/graph", rr.GraphEdges(g.edges, graph_type="directed"), static=True)
        for entity, (_, names) in ROBOT.items():
            log(entity, rr.SeriesLines(names=names), static=True)
        for finger in FINGERS:
            for what, (_, names) in FINGER.items():
                log(f"fv/{finger}/{what}", rr.SeriesLines(names=names), static=True)
        log("cell", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        log("cell/tool", rr.TransformAxes3D(0.1), static=True)
        if self._design is not None:
            log("cell/plates", plate_boxes(self._design), static=True)
            for eid, element in self._design.elements().items():  # on the timelines: placements move them
                self._at(0, self.cell.clock.now(), f"cell/elements/{eid}",
                         element_box({"id": eid, **element}, element.get("status", "planned")))
        log("info", rr.TextDocument(f"tree {tree.document.name} ({tree.document.path}), cell {self.cell.name}, "
                                    f"{1.0 / self.cell.clock.period:g} Hz"), static=True)

    # ---- one tick --------------------------------------------------------------------------------
    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        self.record(tree.count)

    def record(self, tick: int) -> None:
        """Write this tick's row (the snapshot the tree acted on, and the statuses it left) into the
        batch's columns, and log what changed."""
        if self._closed:
            return
        storage = Blackboard.storage
        now = self.cell.clock.now()
        states = (storage[keys.FV_LEFT], storage[keys.FV_RIGHT])
        columns = self._columns
        if not columns.takes(states):  # a full batch, or a new calibration: the rows so far are sent first
            if columns.n:
                self.send()
            columns = self._columns = TickColumns(self.batch, states)
            for finger, state in zip(FINGERS, states):
                if self._origins[finger] is not state.markers.origin:
                    self._calibrated(tick, now, finger, state.markers)
        self._next_tick = tick + 1  # commands sent from now on belong to the next tick
        columns.add(tick, now, storage[keys.ROBOT_POSE], storage[keys.ROBOT_WRENCH], storage[keys.GRIPPER_WIDTH],
                    storage[keys.GRIPPER_OBJECT], states)
        if self._frames is not None and now + 1e-9 >= self._next_image:  # 1e-9: cell time is a sum of periods
            self._images(tick, now, self._frames)
        self._tree(tick, now)
        self._task(tick, now, storage)
        if self._events is not None:
            self._read_events(tick, now, self._events)
        if columns.n == columns.capacity or time.perf_counter() - self._sent_at > self.max_wait:
            self.send()

    def _calibrated(self, tick: int, now: float, finger: str, markers) -> None:
        """New marker origins (a first or new calibration) for the arrows of `finger`."""
        origin = self._origins[finger]
        if origin is None or not np.array_equal(origin, markers.origin):
            w, h = markers.image_size
            self._at(tick, now, f"fv/{finger}/markers", rr.Arrows2D.from_fields(origins=markers.origin))
            self._at(tick, now, f"fv/{finger}/markers/frame", rr.Boxes2D(mins=[0, 0], sizes=[w, h]))
            self._origins_logged = True
        self._origins[finger] = markers.origin

    def _images(self, tick: int, now: float, frames: LatestFrames) -> None:
        """Each finger's newest camera frame as a JPEG under its marker arrows (same pixel axes), kept for
        the batch; encoded by the perception source (pixel mode's workers encode their fingers' frames)."""
        self._next_image = now + self._image_period
        for finger, (jpeg, _) in frames.jpegs(JPEG_QUALITY).items():
            self._sparse[IMAGES[finger]].add(tick, now, jpeg)

    def _tree(self, tick: int, now: float) -> None:
        """Status changes (with the feedback) and new feedback of running nodes; only the nodes whose
        status or feedback changed since the last tick are looked at."""
        seen = list(map(STATE, self._node_objects))
        last = self._seen
        if seen == last:  # the usual tick: no status and no feedback changed
            return
        self._seen = seen
        changed = False
        for k in compress(range(len(seen)), map(ne, seen, last)) if last else range(len(seen)):
            status, feedback = seen[k]
            path = self._paths[k]
            before = self._last[k]
            if status is before:
                if status is Status.RUNNING and feedback != self._feedback[k]:
                    self._feedback[k] = feedback
                    self._sparse["feedback"].add(tick, now, f"{path}: {feedback}")
                continue
            self._feedback[k] = feedback
            self._last[k] = status
            self._statuses[self._order[path]] = status.name
            changed = True
            self._sparse["status"].add(tick, now, (path, status.name, feedback))
            self._sparse["transitions"].add(
                tick, now, (f"{path}: {before.name} -> {status.name}" + (f" ({feedback})" if feedback else ""),
                            "WARN" if status is Status.FAILURE else "INFO"))
        if changed:
            self._sparse["graph"].add(tick, now, self._graph.colours(self._statuses))

    def _task(self, tick: int, now: float, storage: dict) -> None:
        element = storage.get(keys.ELEMENT)
        if element is not self._element:
            self._element = element
            self._element_id = (element or {}).get("id", "element")
            self._at(tick, now, "task/element", rr.TextLog(
                f"element {element.get('id')} on plate {element.get('plate')}" if element else "no element"))
        scan = storage.get(keys.LOAD_SCAN)
        if scan is not self._scan:
            self._scan, self._scan_drawn = scan, 0
        if scan is not None and len(scan["position"]) > self._scan_drawn and now >= self._next_scan:
            self._scan_drawn, self._next_scan = len(scan["position"]), now + SCAN_PERIOD
            self._log_scan(tick, now, scan, self._element_id)
        profile = storage.get(keys.LOAD_PROFILE)
        if profile is not None and profile is not self._profile:
            self._profile = profile
            self._log_profile(tick, now, profile, self._element_id)
            if scan is not None:  # the whole scan is drawn now
                self._scan_drawn = len(scan["position"])

    def _log_scan(self, tick: int, now: float, scan: dict, element: str) -> None:
        """The samples of a load scan so far, drawn as the profile's load line grows."""
        x = np.asarray(scan["position"], float)
        loads = np.asarray(scan["load"][:len(x)], float)
        self._load_line(tick, now, element, x, loads, _profile_scale(loads))

    def _load_line(self, tick: int, now: float, element: str, x: np.ndarray, loads: np.ndarray, scale: float) -> None:
        """A drawing of the load line of `element`'s profile, sent with the batch (one call for all the
        drawings of a scan in it, in their order)."""
        entity = f"task/load_profile/{element}/load"
        self._sparse.setdefault(entity, Sparse()).add(tick, now, np.c_[x, loads * scale])

    def _log_profile(self, tick: int, now: float, profile: dict, element: str) -> None:
        """The scan's load along the plate (x: m along the span; y: load scaled to the drawing's
        height, with the peak's value in its label) and the chosen point."""
        x = np.asarray(profile["position"], float)
        loads, smoothed = np.asarray(profile["load"], float), np.asarray(profile["smoothed"], float)
        scale = _profile_scale(loads)
        base = f"task/load_profile/{element}"
        self._load_line(tick, now, element, x, loads, scale)
        self._at(tick, now, f"{base}/smoothed", rr.LineStrips2D([np.c_[x, smoothed * scale]], colors=[(70, 130, 230)]))
        self._at(tick, now, f"{base}/best", rr.Points2D(
            [[profile["best_position"], profile["best_load"] * scale]], radii=[0.01], colors=[(220, 50, 47)],
            labels=[f"{element}: best {profile['best_position']:.4f} m, load {profile['best_load']:.2f}"]))

    def _read_events(self, tick: int, now: float, events: Path) -> None:
        """The event log's lines appended since the last tick (the log is append-only, so it is opened
        once it exists and its size found by seeking to its end: a path's stat costs several us a tick,
        the open file's ~2 us, the seek ~0.5 us)."""
        if self._events_fd is None:
            if not os.access(events, os.F_OK):
                return
            self._events_fd = os.open(events, os.O_RDONLY)
        size = os.lseek(self._events_fd, 0, os.SEEK_END)
        if size <= self._events_read:
            return
        data = os.pread(self._events_fd, size - self._events_read, self._events_read)
        complete = data[:data.rfind(b"\n") + 1]
        self._events_read += len(complete)
        for line in complete.decode().splitlines():
            try:
                event = json.loads(line)
            except ValueError:
                continue
            self._event(tick, now, event)

    def _event(self, tick: int, now: float, event: dict) -> None:
        kind = event.get("event", "?")
        details = {k: v for k, v in event.items() if k not in ("time", "event", "traceback")}
        level = END_LEVELS.get(event.get("status", ""), "WARN") if kind == "end" else EVENT_LEVELS.get(kind, "INFO")
        self._at(tick, now, "events", rr.TextLog(f"{kind} {json.dumps(details)}", level=level))
        eid = event.get("element")  # every event names the element in work; these change its status
        if self._design is not None and eid in self._design.elements() and kind in ("placing", "placed", "marked"):
            element = {"id": eid, **self._design.elements()[eid], "asbuilt_pose": event.get("pose")}
            self._at(tick, now, f"cell/elements/{eid}", element_box(element, event["status"]))

    def event(self, kind: str, **data: Any) -> None:
        """Record an event the run itself reports (a halt, a crash or the end of a run with no event log);
        also after `close`, until `finish`."""
        self._event(self._next_tick, self.cell.clock.now(), {"event": kind, **data})

    def command(self, device: str, what: str, args: tuple) -> None:
        """Safety-gate observer: a command passed on to `device`."""
        if self._closed:
            return
        kept = tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)
        self._sparse[f"commands/{device}"].add(self._next_tick, self.cell.clock.now(), (what, kept))

    def _at(self, tick: int, now: float, entity: str, archetype: Any) -> None:
        """Log something rare right away at (tick, cell time)."""
        self.stream.set_time("tick", sequence=tick)
        self.stream.set_time("cell_time", duration=now)
        self.stream.log(entity, archetype)

    # ---- sending -----------------------------------------------------------------------------------
    def send(self) -> None:
        """Send the batch's rows as columns, one call per entity: the sparse rows (statuses, commands) first,
        so that a run killed while a batch is written keeps them with any of its ticks."""
        if self._origins_logged:  # logged rows wait in Rerun's batcher: the origins go first, as they came first
            self.stream.flush()
            self._origins_logged = False
        self._send_sparse()
        if self._columns.n:
            self._send_ticks(self._columns)
        self._columns = TickColumns(0)  # the next tick starts the next batch
        self._sent_at = time.perf_counter()

    def _send_ticks(self, columns: TickColumns) -> None:
        """The batch's per-tick rows: the robot's scalars and the tool's transform, then each finger's."""
        send = self.stream.send_columns
        index = columns.index()
        table = columns.robot_table()
        for entity, (start, names) in ROBOT.items():
            send(entity, index, [scalars_column(table[:, start:start + len(names)])])
        send("cell/tool", index, [
            column(rr.Transform3D.descriptor_translation(), rr.components.Translation3DBatch(table[:, 0:3]), 1),
            column(rr.Transform3D.descriptor_quaternion(), rr.components.RotationQuatBatch(quaternions(table[:, 3:6])), 1)])
        for k, finger in enumerate(FINGERS):
            self._send_finger(columns, index, k, finger)

    def _send_finger(self, columns: TickColumns, index: list[rr.TimeColumn], k: int, finger: str) -> None:
        """Finger `k`'s per-tick rows: its scalars and its marker displacement arrows (green: tracked)."""
        send = self.stream.send_columns
        vectors, valid = columns.arrows(k)
        table = columns.finger_table(k, valid)
        for what, (start, names) in FINGER.items():
            send(f"fv/{finger}/{what}", index, [scalars_column(table[:, start:start + len(names)])])
        m = valid.shape[1]
        if m:
            send(f"fv/{finger}/markers", index, [
                column(rr.Arrows2D.descriptor_vectors(), rr.components.Vector2DBatch(vectors.reshape(-1, 2)), m),
                column(rr.Arrows2D.descriptor_colors(),
                       rr.components.ColorBatch(np.where(valid.reshape(-1), VALID_RGBA, INVALID_RGBA)), m)])

    def _send_sparse(self) -> None:
        """The rows kept since the last batch: statuses, transitions, feedback, graph colours, commands,
        camera frames and the drawings of load scans."""
        send = self.stream.send_columns
        taken = self._sparse["status"].take()
        if taken:
            index, rows = taken
            node, status, feedback = (list(c) for c in zip(*rows))
            changes = self._change_column(len(rows))
            send("tree/status", [*index, changes], [column(name, rr.components.TextBatch(texts), 1)  # as rr.AnyValues
                                                    for name, texts in (("node", node), ("status", status),
                                                                        ("feedback", feedback))])
            index, rows = self._sparse["transitions"].take() or ([], [])  # one transition a status change
            text, level = (list(c) for c in zip(*rows))
            send("tree/transitions", [*index, changes], [_text_column(text), column(
                rr.TextLog.descriptor_level(), rr.components.TextLogLevelBatch(level), 1)])
        taken = self._sparse["feedback"].take()
        if taken:
            index, text = taken
            send("tree/feedback", index, [_text_column(text)])
        taken = self._sparse["graph"].take()
        if taken:
            index, colours = taken
            nodes = len(self._graph.paths)
            send("tree/graph", index, [
                column(rr.GraphNodes.descriptor_node_ids(), rr.components.GraphNodeBatch(self._graph.paths * len(colours)),
                       nodes),
                column(rr.GraphNodes.descriptor_colors(), rr.components.ColorBatch(np.concatenate(colours)), nodes)])
        for device in ("arm", "gripper"):
            taken = self._sparse[f"commands/{device}"].take()
            if taken:
                index, rows = taken
                send(f"commands/{device}", index, [_text_column([_command_text(*r) for r in rows])])
        for entity in IMAGES.values():
            taken = self._sparse[entity].take()
            if taken:
                index, jpegs = taken
                send(entity, index, rr.EncodedImage.columns(blob=jpegs, media_type=["image/jpeg"] * len(jpegs)))
        for entity, sparse in self._sparse.items():
            if entity.startswith("task/load_profile/"):
                taken = sparse.take()
                if taken:
                    index, strips = taken
                    send(entity, index, [
                        column(rr.LineStrips2D.descriptor_strips(), rr.components.LineStrip2DBatch(strips), 1),
                        column(rr.LineStrips2D.descriptor_colors(), rr.components.ColorBatch([LOAD_RGB] * len(strips)), 1)])

    def _change_column(self, n: int) -> rr.TimeColumn:
        """The `change` timeline of the next `n` status changes: their number in the recording, so that
        several changes in one tick stay apart (a query by tick keeps one row per tick and entity)."""
        first, self._changes = self._changes, self._changes + n
        return rr.TimeColumn(CHANGE_TIMELINE, sequence=np.arange(first, first + n, dtype=np.int64))

    def close(self) -> None:
        """The run's ticks are over: send what is kept, write it out and detach from the safety gates;
        later ticks are dropped. Events still go in (the run's `end`, written once its verdict is known)
        until `finish`."""
        if self._closed:
            return
        self.send()
        self._closed = True
        for guard in (self.cell.arm, self.cell.gripper):
            if self.command in getattr(guard, "observers", []):
                guard.observers.remove(self.command)
        self.stream.flush()

    def finish(self) -> None:
        """Close, record what the event log gained since the last tick (the `end` event), and end the
        recording (its file is complete)."""
        self.close()
        if not self._finished:
            self._finished = True
            if self._events is not None:
                self._read_events(self._next_tick, self.cell.clock.now(), self._events)
                if self._events_fd is not None:
                    os.close(self._events_fd)
            self.stream.flush()
            self.stream.disconnect()


def _profile_scale(loads: np.ndarray) -> float:
    """Drawing units per unit of load: the largest load drawn PROFILE_HEIGHT high (image y points down)."""
    top = max(float(np.max(np.abs(loads))) if loads.size else 0.0, 1e-9)
    return -PROFILE_HEIGHT / top


def _text_column(texts: list[str]) -> rr.ComponentColumn:
    """A `TextLog` text column, a text a row."""
    return column(rr.TextLog.descriptor_text(), rr.components.TextBatch(texts), 1)


def _command_text(what: str, args: tuple) -> str:
    return f"{what} " + ", ".join(str(np.round(a, 5).tolist()) if isinstance(a, np.ndarray) else
                                  (f"{a:.5g}" if isinstance(a, float) else str(a)) for a in args)


def recording_path(run_dir: Path) -> Path:
    """Where the recording of this session of a run goes: `recording.rrd`, or for a resumed run
    `recording-2.rrd`, `recording-3.rrd`, ... (earlier sessions keep theirs)."""
    path, n = run_dir / RECORDING_FILE, 1
    while path.exists():
        n += 1
        path = run_dir / f"recording-{n}.rrd"
    return path


def run_recorder(tree: BuiltTree, cell: Cell, run_dir: Path, design: DesignModel | None, record: bool = True,
                 live: str | None = None, images_hz: float = IMAGE_HZ) -> RunRecorder:
    """The recorder of one `fvtree run`: to the run directory's recording file (when `record`) and
    live to the viewer at `live` (a gRPC URL), reading the run's event log as it grows, with camera
    frames at `images_hz` a second of cell time when the cell has images."""
    return RunRecorder(tree, cell, recording_path(run_dir) if record else None, live, design,
                       run_dir / "events.jsonl", images_hz=images_hz)
