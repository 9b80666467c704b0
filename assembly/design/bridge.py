"""The design bridge: a run's as-built records (placing, placed, a person's marks) appended to
the event log and forced to disk, then the as-built model replaced atomically, and shown to the
live design links."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from assembly.design.model import DesignModel
from fvfiles.errors import FvtreeError, RecordNotWritten
from fvfiles.json_files import EventLog, atomic_write_json, read_json_lines


class DesignBridge(EventLog):
    """Sends as-built data back to the design model. Each record (`placing` before the fingers
    open, `placed` once the element stands, a person's `marked`) is first appended to the event
    log and forced to disk, then the as-built model file is replaced atomically: a crash or a
    failed write between the two loses nothing, and `catch_up` replays the log on resume.

    `links` (live design links, e.g. `assembly.design.link.mqtt_bridge.MqttLink`) see every event
    after it is logged (`on_event(record, model)`), and hand in design changes at element
    boundaries (`apply_pending(model) -> changed ids`); the file stays the record of truth."""

    RECORDS = ("placing", "placed", "marked")  # events that change an element's status

    def __init__(self, model: DesignModel, asbuilt_path: Path, events_path: Path, links: tuple = (),
                 dispatcher: Any = None):
        super().__init__(events_path)
        self.model = model
        self.asbuilt_path = Path(asbuilt_path)
        self.links = list(links)
        self.dispatcher = dispatcher  # hands out the next element when several cells share a design
        # {element, path, speed} of a way out a stopped session began and did not finish (`catch_up`)
        self.unfinished_retreat: dict | None = None
        atomic_write_json(self.asbuilt_path, model.to_data())

    def next_element(self, remaining: list[str]) -> str | None:
        """The element to build next: the first one left, or the dispatcher's choice (None: all
        done; WAIT: not yet, ask again next tick)."""
        if self.dispatcher is not None:
            return self.dispatcher.next_element(remaining, self.model)
        return remaining[0] if remaining else None

    def event(self, kind: str, **data: Any) -> bool:
        """Log an event (to stderr if the log cannot be written) and show it to the links; whether
        it reached the log. `time` is the wall time; the run's `stamp` adds its tick, cell time
        `t` and the element in work, as the transition log has them."""
        record = self.stamped(kind, data)
        logged = self.write(record)
        self.notify(record)
        return logged

    @property
    def events_path(self) -> Path:
        """The event log (`events.jsonl` of the run directory)."""
        return self.path

    def notify(self, record: dict) -> None:
        """Show a record to the live links only (a passing state such as `picking`, not logged)."""
        for link in self.links:
            link.on_event(record, self.model)

    def at_boundary(self) -> list[str]:
        """Between two elements: apply the design changes the links received (each link checks
        them against the model and reports what it refuses), log them and save the model; the
        elements changed, in order."""
        changed: list[str] = []
        for link in self.links:
            changed += link.apply_pending(self.model)
        if changed:
            self.event("design_updated", elements=changed)
            atomic_write_json(self.asbuilt_path, self.model.to_data())
        return changed

    def fault(self) -> str | None:
        """Why the run must stop now because of a live link (a coordinated cell refused by the
        coordinator, a lease lost, a broker that refuses the login), or None: links may name one
        with `fault()`; the run's stop policy asks after every tick."""
        for link in self.links:
            reason = link.fault() if hasattr(link, "fault") else None
            if reason:
                return reason
        return None

    def close(self) -> None:
        """Settle the as-built file with the log (`settle`), then close the links (each sends what
        it still holds first, within its own time limit)."""
        self.settle()
        for link in self.links:
            link.close()

    def record_placing(self, eid: str, pose, load: float | None) -> None:
        """The element is about to be released at `pose`: a resumed run must not pick it again."""
        self._record("placing", eid, pose, load)

    def record_placement(self, eid: str, pose, load: float | None, retreat: dict | None = None) -> None:
        """The element stands at `pose` carrying `load`; `retreat` ({path: TCP poses, speed}) is the
        way out the arm takes next, which a run resumed before its `retreated` record finishes."""
        extra = None if retreat is None else {"path": np.asarray(retreat["path"], float).round(6).tolist(),
                                              "speed": float(retreat["speed"])}
        self._record("placed", eid, pose, load, retreat=extra)

    def record_retreat(self, eid: str) -> None:
        """The arm has backed out of the placed element (the way out its `placed` record gave)."""
        self.event("retreated", element=eid)

    def mark(self, eid: str, status: str) -> None:
        """A person's verdict on an element left `placing`: `placed` (it stands where recorded)
        or `planned` (build it again)."""
        node = self.model.graph.nodes[eid]
        self._record("marked", eid, node.get("asbuilt_pose"), node.get("measured_load"), status)

    def _record(self, kind: str, eid: str, pose, load: float | None, status: str | None = None,
                retreat: dict | None = None) -> None:
        data = {"element": eid, "status": status or kind,
                "pose": None if pose is None else np.asarray(pose, float).round(6).tolist(),
                "load": None if load is None else round(float(load), 6)}
        self._apply(data)
        logged = self.event(kind, **data, **({} if retreat is None else {"retreat": retreat}))
        try:
            atomic_write_json(self.asbuilt_path, self.model.to_data())
        except OSError as exc:
            kept = self.events_path if logged else "stderr"
            raise RecordNotWritten(f"cannot write the as-built model ({exc.strerror or exc}); "
                                   f"the {kind} record of {eid} is in {kept}", str(self.asbuilt_path)) from exc

    def _apply(self, record: dict, model: DesignModel | None = None) -> None:
        node = (model or self.model).graph.nodes[record["element"]]
        node["status"] = record["status"]
        for name, key in (("asbuilt_pose", "pose"), ("measured_load", "load")):
            if record["status"] == "planned":
                node.pop(name, None)
            else:
                node[name] = record[key]

    def catch_up(self) -> list[str]:
        """Replay the event log's records onto the model (those a failed or interrupted model
        write missed), save it if anything changed, and return the elements changed; note the way
        out of the last placed element when the log ends before its `retreated` record."""
        self.unfinished_retreat = None
        for record in read_json_lines(self.events_path):
            if record.get("event") == "placed" and isinstance(record.get("retreat"), dict):
                self.unfinished_retreat = {"element": record.get("element"), **record["retreat"]}
            elif record.get("event") == "retreated" or record.get("event") in self.RECORDS:
                self.unfinished_retreat = None  # backed out, or another element begun
        changed = self._replay(self.model)
        if changed:
            atomic_write_json(self.asbuilt_path, self.model.to_data())
        return changed

    def _replay(self, model: DesignModel) -> list[str]:
        """Apply the event log's element records to `model`; the elements that changed."""
        changed = []
        for record in read_json_lines(self.events_path):
            if record.get("event") in self.RECORDS and record.get("element") in model.graph:
                node = model.graph.nodes[record["element"]]
                before = (node.get("status"), node.get("asbuilt_pose"), node.get("measured_load"))
                self._apply(record, model)
                if (node.get("status"), node.get("asbuilt_pose"), node.get("measured_load")) != before:
                    changed.append(record["element"])
        return changed

    def settle(self) -> None:
        """Make the as-built file agree with the event log as a session ends: a Ctrl-C between a
        record's two writes (the log, then the file) leaves the file one record behind. The file's
        model with the log replayed onto it is saved when that changed it."""
        try:
            on_disk = DesignModel.load(self.asbuilt_path)
        except FvtreeError:
            return  # unreadable: the check before a resume names it
        if self._replay(on_disk):
            try:
                atomic_write_json(self.asbuilt_path, on_disk.to_data())
            except OSError as exc:
                print(f"{self.asbuilt_path}: behind {self.events_path} ({exc.strerror or exc}); a resume catches "
                      "it up", file=sys.stderr)
