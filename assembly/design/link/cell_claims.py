"""A cell's side of several cells building one design: it asks the coordinator
(`assembly.design.link.coordinator`) for each element, keeps its claim alive while it builds,
reports placing and placed under its lease, and stands in its own model (and simulated world)
what the other cells placed, as the coordinator's retained plan shows it.

With a secret shared with the coordinator (`assembly.design.link.signing`), every request is
signed and only answers and plans signed for this cell count: a forged grant, a forged plan or an
answer to another cell's request is dropped and counted in `forged`.

A cell that is refused stops: a claim or a report refused, a renewal refused (the claim was
revoked or expired), a lease not confirmed for longer than it lasts, a broker that refuses the
login or a link lost for longer than the stated limit make `fault()` name the reason; the run's
stop policy then halts the tree, the arm and the gripper (which keeps what it holds) and the run
ends FAULT. Nothing more is reported under the lost claim."""

from __future__ import annotations

import json
import logging
import threading
import time
import uuid
from collections import OrderedDict

from compas.datastructures import Graph

from assembly.design.link import signing
from assembly.design.link.compas_data import frame_to_pose
from assembly.design.link.topics import DesignTopics
from assembly.design.link.transport import LinkTransport
from assembly.design.link.updates import UpdateError, parse_frame
from assembly.design.model import WAIT, DesignModel

log = logging.getLogger(__name__)
ASK_EVERY = 0.25  # s of wall time between two claims while waiting (the simulated clock runs faster)
RENEW_EVERY = 1.0  # s of wall time between two renewals of a claim
MAX_PLAN_BYTES = 4_000_000  # a retained plan larger than this is not read
KEPT_REQUESTS = 256  # own request ids remembered (answers to others are not this cell's)


class Unreadable(ValueError):
    """A message from the coordinator's topics that is not what it should be: dropped."""


class ClaimClient:
    """The dispatcher and design link of one cell among several (see the module docstring)."""

    def __init__(self, transport: LinkTransport, cell: str, design: str):
        self.transport = transport
        self.cell = cell
        self.topics = DesignTopics(design)
        self.secret = transport.security.secret
        self.granted: tuple[str, str, float] | None = None  # (element, lease, lease_s)
        self._answer: dict | None = None  # the coordinator's answer to the last claim
        self._request: str | None = None
        self._mine: OrderedDict[str, str | None] = OrderedDict()  # ids of requests sent -> their lease
        self._asked = 0.0
        self._confirmed = 0.0  # time.monotonic() the coordinator last confirmed the claim
        self._plan: bytes | None = None  # the coordinator's latest plan, not yet applied
        self._heard = False  # whether the coordinator has answered this cell yet
        self._stop = threading.Event()
        self._fault: str | None = None
        self.refusals: list[str] = []
        self.forged = 0  # messages dropped: unsigned, badly signed, or not for this cell
        transport.listen(self.topics.replies(cell), self._reply)
        transport.listen(self.topics.plan, self._new_plan)
        threading.Thread(target=self._renew_loop, name=f"lease-{cell}", daemon=True).start()

    # ---- the dispatcher -------------------------------------------------------------------------
    def next_element(self, remaining: list[str], model: DesignModel) -> str | None:
        """The element the coordinator granted this cell; WAIT while it has not answered or says
        to wait (or this cell is stopped); None once it says every element is placed, or the
        model shows it."""
        if self._fault is not None:
            return WAIT  # the stop policy ends the run on this tick
        if self.granted is not None:
            return self.granted[0]
        if not remaining:  # every element stands (the coordinator's plan said so): nothing to ask
            return None
        answer, self._answer = self._answer, None
        if answer is not None and answer.get("request") == self._request:
            if answer.get("done"):
                return None
            if answer.get("element") in model.graph and isinstance(answer.get("lease"), str):
                lease_s = answer.get("lease_s", 10.0)
                self.granted = (answer["element"], answer["lease"],
                                float(lease_s) if isinstance(lease_s, (int, float)) else 10.0)
                self._confirmed = time.monotonic()
                return answer["element"]
        if time.monotonic() - self._asked >= ASK_EVERY:
            self._asked = time.monotonic()
            self._request = self._send({"op": "claim"})
        return WAIT

    def _reply(self, payload: bytes) -> None:
        answer = self._read(payload, "answer")
        if answer is None:
            return
        if not isinstance(answer.get("request"), str) or answer["request"] not in self._mine:
            return  # an answer to a request this cell never sent (a replay, or another cell's)
        self._heard = True
        op = answer.get("op")
        if answer.get("refused"):
            self.refusals.append(str(answer["refused"]))
            granted, lease = self.granted, self._mine.get(answer["request"])
            if op == "renew" and (granted is None or granted[1] != lease):
                return  # a renewal sent as the claim ended (placed): nothing lost
            self._halt(f"the coordinator refused {op}: {answer['refused']}")
        elif op == "claim":
            self._answer = answer
        elif op == "renew" and self.granted is not None and answer.get("lease") == self.granted[1]:
            self._confirmed = time.monotonic()

    def _read(self, payload: bytes, what: str) -> dict | None:
        """A message from the coordinator for this cell, checked (None: dropped, and why is logged)."""
        try:
            message = json.loads(payload)
            if not isinstance(message, dict):
                raise Unreadable("not a JSON object")
            if self.secret is not None:
                message = signing.verify(self.secret, message)
                if message.get("cell") != self.cell:
                    raise signing.SignatureError(f"signed for {message.get('cell')!r}, not {self.cell!r}")
        except ValueError as exc:  # SignatureError is one
            self.forged += isinstance(exc, signing.SignatureError)
            log.warning("dropped an %s from the coordinator's topic: %s", what, exc)
            return None
        return message

    def _send(self, request: dict) -> str:
        """Send a request under a new id (signed with this cell's secret); the id."""
        rid = uuid.uuid4().hex[:12]
        self._mine[rid] = request.get("lease")
        while len(self._mine) > KEPT_REQUESTS:
            self._mine.popitem(last=False)
        message = {"cell": self.cell, "request": rid, **request}
        self.transport.send(self.topics.claims, signing.sign(self.secret, message) if self.secret else message)
        return rid

    def _renew_loop(self) -> None:
        while not self._stop.wait(RENEW_EVERY):
            granted = self.granted
            if granted is None or self._fault is not None:
                continue
            self._send({"op": "renew", "element": granted[0], "lease": granted[1]})
            unconfirmed = time.monotonic() - self._confirmed
            if unconfirmed > granted[2]:
                self._halt(f"lease on {granted[0]} lost: the coordinator has not confirmed it for "
                           f"{unconfirmed:.1f} s (it lasts {granted[2]:g} s)")

    def _halt(self, reason: str) -> None:
        if self._fault is None:
            self._fault = reason
            log.error("cell %s stops: %s", self.cell, reason)

    def fault(self) -> str | None:
        """Why this cell must stop now (see the module docstring), or None."""
        transport = self.transport
        if self._fault is None and transport.refused is not None:
            self._halt(f"the broker {transport.url} refused the connection: {transport.refused}")
        lost = transport.lost_for()
        if self._fault is None and lost > transport.security.lost_after:
            self._halt(f"link to the broker {transport.url} lost for {lost:.1f} s "
                       f"(limit {transport.security.lost_after:g} s): the claim cannot be kept")
        return self._fault

    # ---- the link -------------------------------------------------------------------------------
    def on_event(self, record: dict, model: DesignModel) -> None:
        """Report this cell's placing, placed and failed records of its claimed element."""
        kind = record.get("event")
        if self.granted is None or record.get("element") != self.granted[0]:
            return
        eid, lease, _ = self.granted
        if self._fault is None and kind in ("placing", "placed"):
            self._send({"op": kind, "element": eid, "lease": lease, "pose": record.get("pose"),
                        "load": record.get("load")})
        elif self._fault is None and kind == "failed":
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
        plan = None if payload is None else self._read_plan(payload)
        if plan is None:
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
            load = attrs.get("measured_load")
            model.graph.nodes[eid].update(status="placed", asbuilt_pose=pose, cell=attrs["cell"],
                                          measured_load=load if isinstance(load, (int, float)) else None)
            changed.append(eid)
        return changed

    def _read_plan(self, payload: bytes) -> Graph | None:
        """The plan as a Graph, checked (signed for this cell, when signing) before it is decoded."""
        try:
            if len(payload) > MAX_PLAN_BYTES:
                raise ValueError(f"plan of {len(payload)} bytes; at most {MAX_PLAN_BYTES}")
            message = json.loads(payload)
            if not isinstance(message, dict) or not isinstance(message.get("data"), dict):
                raise Unreadable("a plan is a compas_eve message {'dtype', 'data'}")
            if self.secret is not None:
                signing.verify_plan(message, self.cell, self.secret)
            data = message["data"]
            if not isinstance(data.get("node"), dict) or not isinstance(data.get("edge"), dict):
                raise Unreadable("the plan's data is not a COMPAS Graph (node, edge)")
            return Graph.__from_data__(data)
        except signing.SignatureError as exc:
            self.forged += 1
            log.warning("dropped a plan: %s", exc)
        except Exception as exc:  # noqa: BLE001 - any malformed plan is dropped, never raised
            log.warning("unreadable plan from the coordinator: %s", exc)
        return None

    def _new_plan(self, payload: bytes) -> None:
        self._plan = payload

    def close(self) -> None:
        self._stop.set()
