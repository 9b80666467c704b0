"""The check of a run's records before it is resumed: a hand-edited or damaged `events.jsonl` (or
`asbuilt.json`) must not be replayed onto the cell. Every line of the event log is a JSON object
with an `event` name and a finite `time`; each record that changes an element (`placing`,
`placed`, `marked`) names an element of the design, carries a status its event may carry, a pose
of 6 finite numbers whose position lies in the cell's safety box, and a finite load or none (a
`placed` record's way out, which a resume drives the arm along, is poses in the box at a positive
speed; a `retreated` record names a placed element); and
the records of one element follow the order a run writes them: `placing`, then `placed` or a
person's mark, and nothing after `placed` (a `planned` mark of a placed element would build it
a second time: only an element left `placing` may be marked). The last line may be torn (a
crash in the middle of a write): it is ignored, as `read_json_lines` does. Anything else is a
located error naming the file, the line and the field; it quotes the field's value only when it
is short, never a whole line."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from assembly.design.model import DesignModel
from assembly.errors import TreeError
from drivers.cell_file import CellFileError, read_cell_file, resolve_cell_path, section
from drivers.safety import SafetyLimits
from fvfiles.schema_check import short_json

Box = tuple[np.ndarray, np.ndarray]  # the cell's safety box: lowest and highest [x, y, z]

# Which status each record that changes an element may carry, and from which status it may come.
STATUS_OF = {"placing": ("placing",), "placed": ("placed",), "marked": ("placed", "planned")}
COMES_FROM = {"placing": ("planned",), "placed": ("placing",), "marked": ("placing",)}


def cell_box(cell: str) -> Box:
    """The safety box of a cell file (or packaged cell's name), read without building the cell."""
    path = resolve_cell_path(cell)
    data = read_cell_file(path)
    try:
        limits = SafetyLimits.from_dict(section(path, data, "safety"))
    except (TypeError, ValueError) as exc:
        raise CellFileError(path, "safety", str(exc)) from None
    return limits.workspace_min, limits.workspace_max


def check_run_records(run_dir: Path, model: DesignModel, box: Box, events_file: str, asbuilt_file: str) -> None:
    """Check the as-built model's poses and then every record of the event log (see the module
    docstring), against `model` as the run began it; the first problem is a located TreeError."""
    for eid, node in model.elements().items():
        if node.get("asbuilt_pose") is not None:
            problem = _pose_problem(node["asbuilt_pose"], box)
            if problem:
                raise TreeError(f"element {eid}: asbuilt_pose {problem}", str(run_dir / asbuilt_file),
                                path="asbuilt_pose", hint=_HINT)
    _EventCheck(run_dir / events_file, model, box).run()


_HINT = "this run's records were edited or damaged: restore them, or start a new run"


class _EventCheck:
    """One pass over an event log, following each element's status."""

    def __init__(self, path: Path, model: DesignModel, box: Box):
        self.path, self.box = path, box
        self.elements = set(model.elements())
        self.status: dict[str, str] = {}  # what the records so far made of each element

    def run(self) -> None:
        try:
            text = self.path.read_text(encoding="utf-8", errors="replace")
        except FileNotFoundError:
            return
        lines = text.split("\n")
        torn_tail = not text.endswith("\n")  # the last line of a log cut short by a crash
        for number, line in enumerate(lines, 1):
            if not line.strip():
                continue
            try:
                record = json.loads(line)
            except ValueError:
                if torn_tail and number == len(lines):
                    return
                self._fail(number, None, "not a JSON record")
            self.record(number, record)

    def record(self, number: int, record: Any) -> None:
        if not isinstance(record, dict):
            self._fail(number, None, "not a JSON object {event, time, ...}")
        event = record.get("event")
        if not isinstance(event, str) or not event:
            self._fail(number, "event", f"must be an event name, got {short_json(event)}")
        stamp = record.get("time")
        if isinstance(stamp, bool) or not isinstance(stamp, (int, float)) or not math.isfinite(stamp):
            self._fail(number, "time", f"must be a finite number, got {short_json(stamp)}")
        if event in STATUS_OF:
            self.element_record(number, event, record)
        if event == "placed" and "retreat" in record:
            self.way_out(number, record["retreat"])
        if event == "retreated" and self.status.get(str(record.get("element"))) != "placed":
            self._fail(number, "element", f"the way out of {short_json(record.get('element'))}, "
                                          "which is no element placed by then")

    def way_out(self, number: int, retreat: Any) -> None:
        """A `placed` record's way out: {path: [poses in the box], speed: m/s above 0}."""
        if not isinstance(retreat, dict) or not isinstance(retreat.get("path"), list) or not retreat["path"]:
            self._fail(number, "retreat", f"must be {{path: [poses], speed}}, got {short_json(retreat)}")
        for pose in retreat["path"]:
            problem = _pose_problem(pose, self.box)
            if problem:
                self._fail(number, "retreat.path", problem)
        speed = retreat.get("speed")
        if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not (math.isfinite(speed) and speed > 0):
            self._fail(number, "retreat.speed", f"must be a number above 0, got {short_json(speed)}")

    def element_record(self, number: int, event: str, record: dict) -> None:
        eid = record.get("element")
        if not isinstance(eid, str) or eid not in self.elements:
            self._fail(number, "element", f"no element {short_json(eid)} in the run's design")
        status = record.get("status")
        if status not in STATUS_OF[event]:
            self._fail(number, "status", f"a {event} record has status {' or '.join(STATUS_OF[event])}, "
                                         f"got {short_json(status)}")
        pose = record.get("pose")
        if not (pose is None and event == "marked"):
            problem = _pose_problem(pose, self.box)
            if problem:
                self._fail(number, "pose", problem)
        load = record.get("load")
        if load is not None and (isinstance(load, bool) or not isinstance(load, (int, float))
                                 or not math.isfinite(load)):
            self._fail(number, "load", f"must be a finite number or null, got {short_json(load)}")
        before = self.status.get(eid, "planned")
        if before not in COMES_FROM[event]:
            what = ("would build it a second time" if before == "placed"
                    else f"follows {before!r}, which a run never writes before it")
            self._fail(number, "event", f"{event} {status} of {eid}, which is {before!r} by then: this {what}",
                       "only an element left 'placing' is marked, with --mark when resuming")
        self.status[eid] = status

    def _fail(self, number: int, field: str | None, message: str, hint: str = _HINT) -> NoReturn:
        raise TreeError(message, str(self.path), number, field, hint=hint)


def _pose_problem(pose: Any, box: Box) -> str | None:
    """Why `pose` is not 6 finite numbers with its position in the box, or None."""
    if not isinstance(pose, list) or len(pose) != 6 or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pose):
        return f"must be a pose of 6 finite numbers [x, y, z, rx, ry, rz], got {short_json(pose)}"
    lo, hi = box
    if not all(lo[i] <= pose[i] <= hi[i] for i in range(3)):
        return (f"position {[round(float(v), 4) for v in pose[:3]]} is outside the cell's safety box "
                f"{lo.tolist()} .. {hi.tolist()}")
    return None


def drop_torn_tail(path: Path) -> int:
    """Cut a log's last line when a crash tore it (no newline at its end), so that the next record
    appended starts a line of its own; the number of bytes cut."""
    try:
        with open(path, "rb+") as f:
            data = f.read()
            if not data or data.endswith(b"\n"):
                return 0
            keep = data.rfind(b"\n") + 1
            f.truncate(keep)
            f.flush()
            os.fsync(f.fileno())
            return len(data) - keep
    except FileNotFoundError:
        return 0
