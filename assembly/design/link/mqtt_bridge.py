"""The live design link of one cell over MQTT (topics in `assembly.design.link.topics`): it shows
designers the plan, each element's status with its as-built frame and measured load, and the run's
events, and takes in their design updates, which the run applies between two elements.

It rides on the design bridge (`DesignBridge(links=[...])`), which keeps the as-built file as the
record of truth: the link only mirrors what was recorded, and a broker outage delays its messages
(kept and re-sent by the transport) without stopping or slowing the run. On every reconnect it
sends the whole plan again (retained), so a designer who joins late sees the state."""

from __future__ import annotations

import logging
import queue
import time
import uuid
from typing import Any

from assembly.design.link import updates
from assembly.design.link.cell_claims import ClaimClient
from assembly.design.link.compas_data import LIVE_STATUSES, pose_to_frame, to_graph
from assembly.design.link.topics import CellTopics
from assembly.design.link.transport import LinkTransport
from assembly.design.model import DesignModel

log = logging.getLogger(__name__)
STATUS_EVENTS = {"picking": "picking", "placing": "placing", "placed": "placed", "failed": "failed"}
RUN_EVENTS = ("start", "halted", "estop", "fault", "crashed", "timeout", "failed", "design_updated", "end")


class MqttLink:
    """Publishes a run's design state on its cell's topics and queues the updates it receives."""

    def __init__(self, url: str, cell: str, transport: LinkTransport | None = None):
        self.topics = CellTopics(cell)
        self.cell = cell
        self.transport = transport or LinkTransport(url, f"fvtree-{cell}-{uuid.uuid4().hex[:6]}")
        self._inbox: queue.Queue[bytes] = queue.Queue()
        self._live: dict[str, str] = {}  # element -> picking | failed, until the file records more
        self._model: DesignModel | None = None  # the model last seen, to send the plan on reconnect
        self.building: str | None = None  # the element the cell is on
        self._received: set[bytes] = set()  # payloads already queued: QoS 1 may deliver one twice
        self.transport.listen(self.topics.updates, self._receive)
        self.transport.on("ready", self._resend_plan)

    # ---- out ----------------------------------------------------------------------------------
    def on_event(self, record: dict, model: DesignModel) -> None:
        """Mirror one design-bridge record: a status change of an element, or a run event."""
        self._model = model
        kind = record.get("event")
        eid = record.get("element")
        if kind == "marked":
            kind = record.get("status")
        if kind in STATUS_EVENTS and eid is not None:
            self._status(eid, STATUS_EVENTS[kind], record, model)
        if kind in RUN_EVENTS:
            self.transport.send(self.topics.events, {**record, "cell": self.cell})
        if kind == "start":
            self.send_plan(model)

    def _status(self, eid: str, status: str, record: dict, model: DesignModel) -> None:
        self.building = eid if status in ("picking", "placing") else None
        if status in LIVE_STATUSES:
            self._live[eid] = status
        else:
            self._live.pop(eid, None)
        node = model.graph.nodes[eid] if eid in model.graph else {}
        pose = record.get("pose", node.get("asbuilt_pose")) if status in ("placing", "placed") else None
        load = record.get("load", node.get("measured_load")) if status in ("placing", "placed") else None
        self.transport.send(self.topics.status, {
            "element": eid, "status": status, "frame": None if pose is None else pose_to_frame(pose),
            "load": load, "cell": self.cell, "time": record.get("time", time.time())})
        self.send_plan(model)

    def send_plan(self, model: DesignModel) -> None:
        """The live design (statuses as the cell sees them now) as a retained COMPAS Graph."""
        graph = to_graph(model)
        for eid, status in self._live.items():
            if eid in model.graph:
                graph.node_attribute(eid, "status", status)
        self.transport.send(self.topics.plan, graph, retain=True)

    def _resend_plan(self, **_: Any) -> None:
        if self._model is not None:
            self.send_plan(self._model)

    def _report(self, topic: str, data: dict) -> None:
        log.warning("design update %s: %s", data.get("update"), data.get("reason") or data.get("error"))
        self.transport.send(topic, {**data, "cell": self.cell, "time": time.time()})

    # ---- in -----------------------------------------------------------------------------------
    def _receive(self, payload: bytes) -> None:
        """Queue an update for the next element boundary, once: MQTT's QoS 1 delivers at least once."""
        if payload not in self._received:
            self._received.add(payload)
            self._inbox.put(payload)

    def apply_pending(self, model: DesignModel) -> list[str]:
        """Apply the updates received since the last element boundary, in order; report each one
        refused (conflicts and errors topics) and go on. The elements added or changed."""
        changed: list[str] = []
        while True:
            try:
                payload = self._inbox.get_nowait()
            except queue.Empty:
                break
            update = None
            try:
                update = updates.parse(payload)
                changed += updates.apply(model, update, self.building)
            except updates.Conflict as exc:
                assert update is not None  # a conflict is found applying an update, after reading it
                self._report(self.topics.conflicts, {"update": update["update"], "element": exc.element,
                                                     "reason": str(exc)})
            except updates.UpdateError as exc:
                self._report(self.topics.errors, {"update": update["update"] if update else exc.update,
                                                  "error": str(exc), "topic": self.topics.updates})
        if changed:
            self.send_plan(model)
        return list(dict.fromkeys(changed))

    def close(self) -> int:
        """Send what is still queued (a few seconds at most) and disconnect; messages not sent."""
        left = self.transport.close()
        if left:
            log.warning("%d design-link messages never reached %s; the as-built file holds every record, and the "
                        "next run on this cell publishes the plan again", left, self.transport.url)
        return left


def attach(bridge: Any, url: str, cell: str, coordinated: bool = False) -> MqttLink:
    """Link a run's design bridge live to the broker at `url` under `cell`; `coordinated`: the
    elements come from the coordinator of the design (its graph name), shared with other cells."""
    link = MqttLink(url, cell)
    bridge.links.append(link)
    if coordinated:
        claims = ClaimClient(link.transport, cell, bridge.model.graph.graph.get("name") or "design")
        bridge.links.append(claims)
        bridge.dispatcher = claims
    return link
