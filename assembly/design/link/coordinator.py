"""The coordinator: the one authority over a design that several cells build (`fvtree coordinate`).

MQTT has no compare-and-set, so cells never decide among themselves who builds what. Every claim
goes to the coordinator's claims topic, and one thread takes the requests one at a time, in the
order the broker delivered them, against the one model it owns: an element is granted only while
nobody holds a live claim on it, so two requests for the same element are answered one after the
other and the second sees the first's claim. A claim carries a lease id and lasts `lease` seconds
unless its cell renews it; a cell reports placing and placed with its lease id, and a report with a
lease that is not the element's current one is refused. A claim whose cell went silent expires and
its element is free again, unless the cell had reported `placing` (released, maybe standing): that
element is never handed out again automatically. Each element goes to the next cell that asks, in
build order, once everything it waits for is placed (by whichever cell); a cell that asks while
only blocked elements are left is told to wait. A cell that asks again under the same name while
its claim is live (a restarted cell) gets the same element back. After every change the
coordinator publishes its model, retained, as a COMPAS Graph; cells learn the others' placements
from it. The state is saved atomically after every change, so a restarted coordinator resumes.

With the cells' secrets (its credentials file's `cells`), a request counts only when signed by the
cell it names (`assembly.design.link.signing`) under a request id that cell has not used before;
anything else is refused and logged, however it reached the claims topic. Answers and the plan are
signed for each cell, so no other client can pass for the coordinator either.
"""

from __future__ import annotations

import json
import logging
import math
import queue
import threading
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from assembly.design.link import signing
from assembly.design.link.compas_data import to_graph
from assembly.design.link.security import LinkSecurity
from assembly.design.link.topics import DesignTopics, check_name
from assembly.design.link.transport import LinkTransport
from assembly.design.model import DesignModel
from assembly.errors import TreeError
from fvfiles.json_files import atomic_write_json

log = logging.getLogger(__name__)
OPS = ("claim", "renew", "placing", "placed", "failed")
MAX_BYTES = 16_000
KEPT_REQUESTS = 4096  # request ids remembered per cell, to refuse a replayed request


@dataclass
class Claim:
    cell: str
    element: str
    lease: str
    expires: float  # time.monotonic() deadline


class Coordinator:
    """Owns a design model and answers the cells' claims (see the module docstring)."""

    def __init__(self, model: DesignModel, url: str, lease: float = 10.0, state_path: Path | None = None,
                 clock=time.monotonic, security: LinkSecurity | None = None):
        self.model = model
        self.name = check_name(model.graph.graph.get("name") or "design", "design name")
        self.topics = DesignTopics(self.name)
        self.lease = lease
        self.state_path = state_path
        self.clock = clock
        self.claims: dict[str, Claim] = {}  # element -> its live claim
        self.log: list[dict] = []  # what happened, in order: grants, placements, expiries, refusals
        self._inbox: queue.Queue[bytes | None] = queue.Queue()
        self.secrets: dict[str, bytes] = dict(security.cells) if security is not None else {}
        self._seen: dict[str, dict[str, None]] = {}  # cell -> request ids taken (insertion-ordered)
        self.transport = LinkTransport(url, f"fvtree-coordinator-{self.name}-{uuid.uuid4().hex[:6]}", security)
        self.transport.listen(self.topics.claims, self._inbox.put)
        self.transport.on("ready", lambda **_: self.publish())
        self._thread: threading.Thread | None = None

    # ---- the one thread that decides ------------------------------------------------------------
    def start(self) -> Coordinator:
        self._thread = threading.Thread(target=self.serve, name="coordinator", daemon=True)
        self._thread.start()
        return self

    def serve(self, until_done: bool = False) -> None:
        """Take requests one at a time until stopped (or, with `until_done`, every element is placed).
        The plan is published first (and again on every reconnect): the broker may still retain an
        earlier coordinator's, which cells must not build from."""
        self.publish()
        while True:
            try:
                payload = self._inbox.get(timeout=0.2)
            except queue.Empty:
                payload = b""
            if payload is None:
                return
            self._expire()
            if payload:
                self._handle(payload)
            if until_done and self.done():
                return

    def stop(self) -> None:
        self._inbox.put(None)
        if self._thread is not None:
            self._thread.join(timeout=10)
        self.transport.close()

    def done(self) -> bool:
        return all(self.model.is_placed(e) for e in self.model.build_order())

    def _handle(self, payload: bytes) -> None:
        try:
            request = self._parse(payload)
        except ValueError as exc:
            self._record("refused", error=str(exc))
            self.transport.send(self.topics.errors, {"error": str(exc), "topic": self.topics.claims})
            return
        answer = getattr(self, "_" + request["op"])(request)
        cell = request["cell"]
        message = {"request": request.get("request"), "op": request["op"], "cell": cell, **answer}
        self.transport.send(self.topics.replies(cell), signing.sign(self.secrets[cell], message)
                            if self.secrets else message)

    def _parse(self, payload: bytes) -> dict:
        if len(payload) > MAX_BYTES:
            raise ValueError(f"request of {len(payload)} bytes; at most {MAX_BYTES}")
        try:
            request = json.loads(payload.decode("utf-8"))
        except (UnicodeDecodeError, ValueError, RecursionError) as exc:
            raise ValueError(f"not JSON: {exc}") from None
        if not isinstance(request, dict) or request.get("op") not in OPS:
            raise ValueError(f"a request is an object with 'op' one of {', '.join(OPS)}")
        try:
            check_name(request.get("cell"), "cell name")
        except TreeError as exc:
            raise ValueError(exc.message) from None
        if self.secrets:
            self._check_signed(request)
        if request["op"] != "claim" and not isinstance(request.get("lease"), str):
            raise ValueError(f"{request['op']}: field 'lease' (the lease id of the claim) is missing")
        if request["op"] in ("placing", "placed") and not _pose(request.get("pose")):
            raise ValueError(f"{request['op']}: field 'pose' must be 6 finite numbers")
        return request

    def _check_signed(self, request: dict) -> None:
        """ValueError unless the request is signed by the cell it names, under a new request id."""
        cell = request["cell"]
        if cell not in self.secrets:
            raise ValueError(f"{request['op']} from {cell!r}: not a cell of this design (no secret for it)")
        try:
            signing.verify(self.secrets[cell], request)
        except signing.SignatureError as exc:
            raise ValueError(f"{request['op']} in the name of {cell}: {exc}") from None
        rid = request.get("request")
        seen = self._seen.setdefault(cell, {})
        if not isinstance(rid, str) or rid in seen:
            raise ValueError(f"{request['op']} from {cell}: request id {rid!r} used before (a replay)")
        seen[rid] = None
        if len(seen) > KEPT_REQUESTS:
            del seen[next(iter(seen))]

    # ---- requests -------------------------------------------------------------------------------
    def _claim(self, request: dict) -> dict:
        cell = request["cell"]
        held = next((c for c in self.claims.values() if c.cell == cell), None)
        if held is not None and self.model.graph.nodes[held.element].get("status") == "placing":
            return self._refuse(request, f"{held.element} was being released by {cell}: check it in the cell first")
        if held is not None:  # a restarted cell: the same element, the same lease
            held.expires = self.clock() + self.lease
            return self._grant_answer(held)
        if self.done():
            return {"done": True}
        for eid in self.model.build_order():
            node = self.model.graph.nodes[eid]
            if node.get("status", "planned") in ("placed", "placing") or eid in self.claims:
                continue
            if all(self.model.is_placed(p) for p in self.model.graph.predecessors(eid)):
                claim = Claim(cell, eid, uuid.uuid4().hex, self.clock() + self.lease)
                self.claims[eid] = claim
                self._record("granted", cell=cell, element=eid, lease=claim.lease)
                return self._grant_answer(claim)
        waiting = [e for e in self.model.build_order() if not self.model.is_placed(e)]
        return {"wait": True, "unplaced": waiting}

    def _grant_answer(self, claim: Claim) -> dict:
        return {"element": claim.element, "lease": claim.lease, "lease_s": self.lease}

    def _own(self, request: dict) -> Claim | None:
        claim = (self.claims.get(request["element"]) if "element" in request else None) or next(
            (c for c in self.claims.values() if c.lease == request["lease"]), None)
        return claim if claim is not None and claim.lease == request["lease"] and claim.cell == request["cell"] else None

    def _renew(self, request: dict) -> dict:
        claim = self._own(request)
        if claim is None:
            return self._refuse(request, "no live claim with this lease (it expired, or was never granted)")
        claim.expires = self.clock() + self.lease
        return {"element": claim.element, "lease": claim.lease}

    def _placing(self, request: dict) -> dict:
        return self._report(request, "placing")

    def _placed(self, request: dict) -> dict:
        return self._report(request, "placed")

    def _report(self, request: dict, status: str) -> dict:
        claim = self._own(request)
        if claim is None or claim.element != request.get("element"):
            return self._refuse(request, f"{request.get('element')} is not claimed by {request['cell']} under this lease")
        node = self.model.graph.nodes[claim.element]
        node.update(status=status, asbuilt_pose=[float(v) for v in request["pose"]], cell=claim.cell,
                    measured_load=request.get("load") if _number(request.get("load")) else None)
        if status == "placed":
            del self.claims[claim.element]
        else:
            claim.expires = self.clock() + self.lease
        self._record(status, cell=claim.cell, element=claim.element, load=node["measured_load"])
        self._changed()
        return {"element": claim.element, "status": status}

    def _failed(self, request: dict) -> dict:
        claim = self._own(request)
        if claim is None:
            return self._refuse(request, "no live claim with this lease")
        del self.claims[claim.element]
        status = self.model.graph.nodes[claim.element].get("status", "planned")  # placing: a person checks it
        self._record("failed", cell=claim.cell, element=claim.element, status=status)
        return {"element": claim.element, "status": status}

    def _refuse(self, request: dict, reason: str) -> dict:
        self._record("refused", cell=request["cell"], element=request.get("element"), reason=reason)
        return {"refused": reason}

    # ---- time and state -------------------------------------------------------------------------
    def _expire(self) -> None:
        now = self.clock()
        for eid, claim in list(self.claims.items()):
            if claim.expires > now:
                continue
            if self.model.graph.nodes[eid].get("status") == "placing":
                if claim.cell:  # once: it stays placing, nobody gets it
                    self._record("stuck", cell=claim.cell, element=eid,
                                 reason=f"{claim.cell} went silent while releasing {eid}: check the cell")
                    claim.cell = ""
                continue
            del self.claims[eid]
            self._record("expired", cell=claim.cell, element=eid)

    def _record(self, what: str, **data: Any) -> None:
        entry = {"time": time.time(), "what": what, **data}
        self.log.append(entry)
        log.info("%s", entry)
        self.transport.send(self.topics.log, entry)

    def _changed(self) -> None:
        if self.state_path is not None:
            atomic_write_json(self.state_path, self.model.to_data())
        self.publish()

    def publish(self) -> None:
        """The model, retained: the cells stand what others placed."""
        encoded = self.transport.codec.encode(to_graph(self.model))
        self.transport.send_raw(self.topics.plan, signing.sign_plan(encoded, self.secrets) if self.secrets
                                else encoded, retain=True)


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _pose(value: Any) -> bool:
    return isinstance(value, list) and len(value) == 6 and all(_number(v) for v in value)


def load_state(design: Path, state_path: Path | None) -> DesignModel:
    """The coordinator's model: its saved state if there is one (a restart), else the design."""
    if state_path is not None and state_path.exists():
        return DesignModel.load(state_path)
    return DesignModel.load(design)
