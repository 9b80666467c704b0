"""A cell's side of several cells building one design: it asks the coordinator
(`assembly.design.link.coordinator`) for each element, keeps its claim alive while it builds,
reports placing and placed under its lease, and stands in its own model (and simulated world)
what the other cells placed, as the coordinator's retained plan shows it."""

from __future__ import annotations

import json
import logging
import threading
import time
import uuid

from compas.datastructures import Graph

from assembly.design.link.compas_data import frame_to_pose
from assembly.design.link.topics import DesignTopics
from assembly.design.link.transport import LinkTransport
from assembly.design.link.updates import UpdateError, parse_frame
from assembly.design.model import WAIT, DesignModel

log = logging.getLogger(__name__)
ASK_EVERY = 0.25  # s of wall time between two claims while waiting (the simulated clock runs faster)


class ClaimClient:
    """The dispatcher and design link of one cell among several (see the module docstring)."""

    def __init__(self, transport: LinkTransport, cell: str, design: str):
        self.transport = transport
        self.cell = cell
        self.topics = DesignTopics(design)
        self.granted: tuple[str, str, float] | None = None  # (element, lease, lease_s)
        self._answer: dict | None = None  # the coordinator's answer to the last claim
        self._request: str | None = None
        self._asked = 0.0
        self._plan: bytes | None = None  # the coordinator's latest plan, not yet applied
        self._heard = False  # whether the coordinator has answered this cell yet
        self._stop = threading.Event()
        self.refusals: list[str] = []
        transport.listen(self.topics.replies(cell), self._reply)
        transport.listen(self.topics.plan, self._new_plan)
        threading.Thread(target=self._renew_loop, name=f"lease-{cell}", daemon=True).start()

    # ---- the dispatcher -------------------------------------------------------------------------
    def next_element(self, remaining: list[str], model: DesignModel) -> str | None:
        """The element the coordinator granted this cell; WAIT while it has not answered or says
        to wait; None once it says every element is placed, or the model shows it."""
        if self.granted is not None:
            return self.granted[0]
        if not remaining:  # every element stands (the coordinator's plan said so): nothing to ask
            return None
        answer, self._answer = self._answer, None
        if answer is not None and answer.get("request") == self._request:
            if answer.get("done"):
                return None
            if answer.get("element") in model.graph:
                self.granted = (answer["element"], answer["lease"], float(answer.get("lease_s", 10.0)))
                return answer["element"]
            if answer.get("refused"):
                self.refusals.append(answer["refused"])
        if time.monotonic() - self._asked >= ASK_EVERY:
            self._request, self._asked = uuid.uuid4().hex[:8], time.monotonic()
            self._send({"op": "claim"})
        return WAIT

    def _reply(self, payload: bytes) -> None:
        try:
            answer = json.loads(payload)
        except ValueError:
            log.warning("unreadable answer from the coordinator: %r", payload[:80])
            return
        self._heard = True
        if answer.get("op") == "claim":
            self._answer = answer
        elif answer.get("refused"):
            self.refusals.append(answer["refused"])
            log.warning("coordinator refused %s: %s", answer.get("op"), answer["refused"])

    def _send(self, request: dict) -> None:
        self.transport.send(self.topics.claims, {"cell": self.cell, "request": self._request, **request})

    def _renew_loop(self) -> None:
        while not self._stop.wait(1.0):
            granted = self.granted
            if granted is not None:
                self._send({"op": "renew", "element": granted[0], "lease": granted[1]})

    # ---- the link -------------------------------------------------------------------------------
    def on_event(self, record: dict, model: DesignModel) -> None:
        """Report this cell's placing, placed and failed records of its claimed element."""
        kind = record.get("event")
        if self.granted is None or record.get("element") != self.granted[0]:
            return
        eid, lease, _ = self.granted
        if kind in ("placing", "placed"):
            self._send({"op": kind, "element": eid, "lease": lease, "pose": record.get("pose"),
                        "load": record.get("load")})
        elif kind == "failed":
            self._send({"op": "failed", "element": eid, "lease": lease})
        if kind in ("placed", "failed"):
            self.granted = None

    def apply_pending(self, model: DesignModel) -> list[str]:
        """Stand in the model what the coordinator's latest plan shows placed and the model does
        not: by other cells, or by this cell before a restart. Read as plain data (frames only).
        Not before the coordinator has answered: a plan the broker retained may be an earlier
        coordinator's (all placed), and would end this cell's build before it began."""
        if not self._heard:
            return []
        payload, self._plan = self._plan, None
        if payload is None:
            return []
        try:
            plan = Graph.__from_data__(json.loads(payload)["data"])
        except (ValueError, KeyError, TypeError, SyntaxError):
            log.warning("unreadable plan from the coordinator")
            return []
        changed = []
        for eid, attrs in plan.nodes(data=True):
            if eid not in model.graph or attrs.get("status") != "placed" or not attrs.get("cell") or model.is_placed(eid):
                continue
            try:
                pose = frame_to_pose(parse_frame(attrs.get("asbuilt_frame"), f"{eid}.asbuilt_frame"))
            except UpdateError as exc:
                log.warning("coordinator plan: %s", exc)
                continue
            model.graph.nodes[eid].update(status="placed", asbuilt_pose=pose, cell=attrs["cell"],
                                          measured_load=attrs.get("measured_load"))
            changed.append(eid)
        return changed

    def _new_plan(self, payload: bytes) -> None:
        self._plan = payload

    def close(self) -> None:
        self._stop.set()
