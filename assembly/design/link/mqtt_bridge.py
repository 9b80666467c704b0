"""The live design link of one cell over MQTT (topics in `assembly.design.link.topics`): it shows
designers the plan, each element's status with its as-built frame and measured load, and the run's
events, and takes in their design updates, which the run applies between two elements.

It rides on the design bridge (`DesignBridge(links=[...])`), which keeps the as-built file as the
record of truth: the link only mirrors what was recorded, and a broker outage delays its messages
(kept and re-sent by the transport) without stopping or slowing the run. On every reconnect it
sends the whole plan again (retained), so a designer who joins late sees the state.

Updates are read when they arrive, before anything is queued: a message too large, not an update,
or with a pose outside the cell's workspace (`assembly.design.link.workspace`) is refused at once on
the errors topic; a repeat of one already taken (QoS 1 may deliver twice) is dropped. What passes
waits for the next element boundary in a bounded queue (MAX_QUEUED updates, MAX_QUEUED_BYTES):
when it is full the oldest is dropped and reported. Refusals are reported at most REPORTS_PER_S
a second (the rest are counted in the next report), so a flood costs neither memory nor the
broker's bandwidth. A broker that refuses this cell's login mid-run is its `fault()`."""

from __future__ import annotations

import hashlib
import logging
import threading
import time
import uuid
from collections import OrderedDict, deque
from typing import Any

from assembly.design.link import updates
from assembly.design.link.cell_claims import ClaimClient
from assembly.design.link.compas_data import LIVE_STATUSES, pose_to_frame, to_graph
from assembly.design.link.security import ENV_SECRET, LinkError, LinkSecurity
from assembly.design.link.topics import CellTopics
from assembly.design.link.transport import LinkTransport
from assembly.design.link.workspace import Workspace
from assembly.design.model import DesignModel

log = logging.getLogger(__name__)
STATUS_EVENTS = {"picking": "picking", "placing": "placing", "placed": "placed", "failed": "failed"}
RUN_EVENTS = ("start", "halted", "estop", "fault", "crashed", "timeout", "failed", "retreated", "design_updated",
              "end")
MAX_QUEUED = 32  # updates waiting for the next element boundary
MAX_QUEUED_BYTES = 1_000_000  # their raw size together
KEPT_DIGESTS = 1024  # digests of the last messages taken, to drop repeats
REPORTS_PER_S = 20.0  # refusals answered per second at most (a burst of as many)


class MqttLink:
    """Publishes a run's design state on its cell's topics and queues the updates it receives."""

    def __init__(self, url: str, cell: str, transport: LinkTransport | None = None,
                 security: LinkSecurity | None = None, workspace: Workspace | None = None):
        self.topics = CellTopics(cell)
        self.cell = cell
        self.workspace = workspace
        self.transport = transport or LinkTransport(url, f"fvtree-{cell}-{uuid.uuid4().hex[:6]}", security)
        self._lock = threading.Lock()
        self._inbox: deque[tuple[int, dict]] = deque()  # (raw size, parsed update), oldest first
        self._queued_bytes = 0
        self._digests: OrderedDict[bytes, None] = OrderedDict()  # of the last messages taken
        self._live: dict[str, str] = {}  # element -> picking | failed, until the file records more
        self._model: DesignModel | None = None  # the model last seen, to send the plan on reconnect
        self.building: str | None = None  # the element the cell is on
        self.received = self.refused = self.dropped = self.repeats = 0  # messages, by what became of them
        self._tokens, self._filled, self._unreported = REPORTS_PER_S, time.monotonic(), 0
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
        """Answer a refused update, within the rate limit (the rest are counted, then reported)."""
        now = time.monotonic()
        with self._lock:
            self._tokens = min(REPORTS_PER_S, self._tokens + (now - self._filled) * REPORTS_PER_S)
            self._filled = now
            if self._tokens < 1.0:
                self._unreported += 1
                return
            self._tokens -= 1.0
            unreported, self._unreported = self._unreported, 0
        log.warning("design update %s: %s", data.get("update"), data.get("reason") or data.get("error"))
        extra = {"unreported": unreported} if unreported else {}
        self.transport.send(topic, {**data, **extra, "cell": self.cell, "time": time.time()})

    def _error(self, update: Any, error: str) -> None:
        self._report(self.topics.errors, {"update": update, "error": error, "topic": self.topics.updates})

    # ---- in -----------------------------------------------------------------------------------
    def _receive(self, payload: bytes) -> None:
        """Read an update as it arrives (network thread): refuse it at once, or queue it for the
        next element boundary (see the module docstring)."""
        self.received += 1
        if len(payload) <= updates.MAX_BYTES:  # a larger one is refused by parse, unread
            digest = hashlib.sha256(payload).digest()
            with self._lock:
                repeat = digest in self._digests
                self._digests[digest] = None
                if len(self._digests) > KEPT_DIGESTS:
                    self._digests.popitem(last=False)
            if repeat:
                self.repeats += 1
                return
        try:
            update = updates.parse(payload)
        except updates.UpdateError as exc:
            self.refused += 1
            self._error(exc.update, str(exc))
            return
        problems = [p for p in map(self.workspace.problem, update["elements"]) if p] if self.workspace else []
        if problems:
            self.refused += 1
            self._error(update["update"], f"refused: {problems[0]}")
            return
        with self._lock:
            self._inbox.append((len(payload), update))
            self._queued_bytes += len(payload)
            dropped = []
            while len(self._inbox) > MAX_QUEUED or self._queued_bytes > MAX_QUEUED_BYTES:
                size, old = self._inbox.popleft()
                self._queued_bytes -= size
                dropped.append(old["update"])
        for old_id in dropped:
            self.dropped += 1
            self._error(old_id, f"dropped unapplied: more than {MAX_QUEUED} updates or {MAX_QUEUED_BYTES} bytes "
                                "arrived before the next element boundary (send it again)")

    def pending(self) -> int:
        """Updates waiting for the next element boundary."""
        return len(self._inbox)

    def apply_pending(self, model: DesignModel) -> list[str]:
        """Apply the updates received since the last element boundary, in order; report each one
        refused (conflicts and errors topics) and go on. The elements added or changed."""
        changed: list[str] = []
        while True:
            with self._lock:
                if not self._inbox:
                    break
                size, update = self._inbox.popleft()
                self._queued_bytes -= size
            try:
                changed += updates.apply(model, update, self.building)
            except updates.Conflict as exc:
                self._report(self.topics.conflicts, {"update": update["update"], "element": exc.element,
                                                     "reason": str(exc)})
            except updates.UpdateError as exc:
                self._error(update["update"], str(exc))
        if changed:
            self.send_plan(model)
        return list(dict.fromkeys(changed))

    def fault(self) -> str | None:
        """Why the run must stop: the broker refused this cell's login (revoked mid-run), else None.
        A link merely down only delays these messages (the as-built file is the record)."""
        if self.transport.refused is not None:
            return f"the broker {self.transport.url} refused the connection: {self.transport.refused}"
        return None

    def close(self) -> int:
        """Send what is still queued (a few seconds at most) and disconnect; messages not sent."""
        left = self.transport.close()
        if left:
            log.warning("%d design-link messages never reached %s; the as-built file holds every record, and the "
                        "next run on this cell publishes the plan again", left, self.transport.url)
        return left


def attach(bridge: Any, url: str, cell: str, coordinated: bool = False, security: LinkSecurity | None = None,
           workspace: Workspace | None = None) -> MqttLink:
    """Link a run's design bridge live to the broker at `url` under `cell`, logged in with
    `security`, taking only updates inside `workspace`; `coordinated`: the elements come from
    the coordinator of the design (its graph name), shared with other cells. LinkError when the
    broker cannot be reached or refuses the login."""
    link = MqttLink(url, cell, security=security, workspace=workspace)
    bridge.links.append(link)
    if coordinated:
        claims = ClaimClient(link.transport, cell, bridge.model.graph.graph.get("name") or "design")
        bridge.links.append(claims)
        bridge.dispatcher = claims
    return link


def attach_options(bridge: Any, options: Any, cell: str, cell_file: str) -> MqttLink:
    """`attach` with a run's `LinkOptions` (assembly.run.options): its credentials and TLS files
    loaded and checked, and the workspace of `cell_file` (the run's cell) for design updates."""
    security = LinkSecurity.load(options.credentials, ca=options.tls_ca, cert=options.tls_cert, key=options.tls_key,
                                 lost_after=options.lost_after)
    if options.coordinated and security.secret is None and not options.unsigned:
        raise LinkError("no signing secret: another client on the broker could pass for this cell or hand it "
                        "forged grants", str(options.credentials or "--credentials"),
                        hint=f"give 'secret' in the credentials file or {ENV_SECRET}, or --unsigned on a private broker")
    return attach(bridge, options.url, cell, options.coordinated, security, Workspace.of_cell(cell_file))
