"""`fvtree run --groot2`: a running tree served to Groot2 (or any client of its protocol) over ZeroMQ.

As BT.CPP's `Groot2Publisher` does, the monitor binds a REP socket on PORT, answered by a thread
of its own, and a PUB socket on PORT + 1, on which the tick thread announces breakpoints reached.
It binds 127.0.0.1 unless told another address. The run loop calls it after every tick
(`__call__`): it rebuilds the status buffer and, while Groot2 records, notes each node whose
status changed (a status that changes and changes back within one tick is not seen, as in
`transitions.jsonl`), timed by the cell's clock from when recording started. Up to
`MAX_TRANSITIONS` wait for Groot2 to fetch them; older ones are dropped.

Served: the tree (`FULLTREE`, assembly.interop.groot2.tree_xml), the statuses, the blackboards, the
hooks (assembly.interop.groot2.breakpoints; refused with a reason where the run cannot honour them)
and the transition recording. What fails gets BT.CPP's error reply, and the server goes on.
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections import deque
from collections.abc import Callable

import py_trees
import zmq
from py_trees.common import Status

from assembly.interop.groot2 import DEFAULT_PORT, Groot2Error
from assembly.interop.groot2.blackboard import blackboards_dump
from assembly.interop.groot2.breakpoints import MAX_SILENCE, Breakpoints
from assembly.interop.groot2.protocol import (
    IDLE_FROM,
    Header,
    ProtocolError,
    RequestType,
    encode_statuses,
    encode_transitions,
    error_reply,
    hook_target,
    parse_hooks,
    reply_header,
)
from assembly.interop.groot2.protocol import Status as BtStatus
from assembly.interop.groot2.tree_xml import MonitorTree

MAX_TRANSITIONS = 100_000
POLL_MS = 100
BT_STATUS = {Status.INVALID: BtStatus.IDLE, Status.RUNNING: BtStatus.RUNNING, Status.SUCCESS: BtStatus.SUCCESS,
             Status.FAILURE: BtStatus.FAILURE}


class Groot2Monitor:
    """The Groot2 server of one run: `tree` (from `monitor_tree`) over `nodes` (path -> node of
    the built tree), timed by `now` (the cell clock); `hooks_refused` says why breakpoints are not
    honoured here (None: they are)."""

    def __init__(self, tree: MonitorTree, nodes: dict[str, py_trees.behaviour.Behaviour], now: Callable[[], float],
                 port: int = DEFAULT_PORT, host: str = "127.0.0.1", hooks_refused: str | None = None):
        self.tree = tree
        self.now = now
        self.tree_id = os.urandom(16)
        self._nodes = sorted(((tree.uids[path], node) for path, node in nodes.items()), key=lambda un: un[0])
        self._seen: list[Status] = [Status.INVALID] * len(self._nodes)
        self._ran: list[int] = [0] * len(self._nodes)  # each node's last status other than idle
        self._status_buffer = encode_statuses([(uid, BtStatus.IDLE) for uid, _ in self._nodes])
        self._recording_since: float | None = None  # cell time
        self._transitions: deque[tuple[int, int, int]] = deque(maxlen=MAX_TRANSITIONS)
        self._lock = threading.Lock()
        self.breakpoints = Breakpoints({uid: node for uid, node in self._nodes}, hooks_refused)
        self.breakpoints.on_pause = self.publish
        self.breakpoints.notify = self._notify
        self._last_request = time.monotonic()
        self._context = zmq.Context()
        sockets: list[zmq.Socket] = []
        try:
            for kind, at in ((zmq.REP, port), (zmq.PUB, port + 1)):
                sockets.append(self._context.socket(kind))
                sockets[-1].setsockopt(zmq.LINGER, 0)
                sockets[-1].bind(f"tcp://{host}:{at}")
        except zmq.ZMQError as exc:
            for socket in sockets:
                socket.close()
            self._context.term()
            raise Groot2Error(f"--groot2: cannot listen on {host}:{at} ({exc.strerror})",
                              hint="choose another port: --groot2 PORT (it and PORT+1 must be free)") from None
        self._server, self._publisher = sockets
        self.address = f"{host}:{port}"
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="groot2", daemon=True)
        self._thread.start()

    # ---- the tick's side -------------------------------------------------------------------------
    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        """Post-tick handler: publish this tick's statuses."""
        self.publish()

    def publish(self) -> None:
        """Rebuild the status buffer from the nodes' statuses, noting the changes while recording."""
        statuses = [node.status for _, node in self._nodes]
        if statuses == self._seen:
            return
        changed: list[tuple[int, int, int]] = []
        recording = self._recording_since
        usec = 0 if recording is None else max(0, round((self.now() - recording) * 1e6))
        for i, (status, seen) in enumerate(zip(statuses, self._seen)):
            if status is not seen:
                code = BT_STATUS.get(status, BtStatus.IDLE)
                if code != BtStatus.IDLE:
                    self._ran[i] = code
                if recording is not None:
                    changed.append((usec, self._nodes[i][0], code))
        self._seen = statuses
        buffer = encode_statuses([(uid, BT_STATUS.get(s, 0) or (IDLE_FROM + ran if ran else 0))
                                  for (uid, _), s, ran in zip(self._nodes, statuses, self._ran)])
        with self._lock:
            self._status_buffer = buffer
            if self._recording_since is not None:
                self._transitions.extend(changed)

    def bind(self, hold: Callable[[str], None]) -> None:
        """The run loop's checks while a breakpoint pauses the tick at the node of a path (it raises to
        stop the run)."""
        paths = {uid: path for path, uid in self.tree.uids.items()}
        self.breakpoints.hold = lambda uid: hold(paths[uid])

    @property
    def paused_s(self) -> float:
        """Wall time spent paused at breakpoints (the run's pacing leaves it out)."""
        return self.breakpoints.paused_s

    def _notify(self, uid: int) -> None:
        header = Header(RequestType.BREAKPOINT_REACHED, int.from_bytes(os.urandom(4), "little")).encode()
        try:
            self._publisher.send_multipart([header, str(uid).encode()], zmq.NOBLOCK)
        except zmq.ZMQError:
            pass  # nobody subscribed: the breakpoint waits all the same

    # ---- the server thread -----------------------------------------------------------------------
    def _serve(self) -> None:
        poller = zmq.Poller()
        poller.register(self._server, zmq.POLLIN)
        connected = True
        try:
            while not self._stop.is_set():
                if poller.poll(POLL_MS):
                    frames = self._server.recv_multipart()
                    self._last_request = time.monotonic()
                    self._server.send_multipart(self.handle(frames))
                alive = time.monotonic() - self._last_request < MAX_SILENCE
                if alive != connected:  # Groot2 went away, or came back: hooks off, or on again
                    connected = alive
                    self.breakpoints.enable_all(alive)
        except zmq.ZMQError:
            if not self._stop.is_set():
                raise
        finally:
            self._server.close()

    def handle(self, frames: list[bytes]) -> list[bytes]:
        """The reply to one request (BT.CPP's error reply for one it cannot serve)."""
        try:
            header = Header.decode(frames[0] if frames else b"")
            kind = RequestType(header.type)
        except (ProtocolError, ValueError) as exc:
            return error_reply(str(exc) if isinstance(exc, ProtocolError) else "Request not recognized")
        try:
            body = self._reply(kind, frames)
        except ProtocolError as exc:
            return error_reply(str(exc))
        return [reply_header(header, self.tree_id), *body]

    def _reply(self, kind: RequestType, frames: list[bytes]) -> list[bytes]:
        if kind in NEEDS_PAYLOAD and len(frames) != 2:
            raise ProtocolError("must be 2 parts message")
        payload = frames[1] if len(frames) > 1 else b""
        bp = self.breakpoints
        if kind == RequestType.FULLTREE:
            return [self.tree.xml.encode()]
        if kind == RequestType.STATUS:
            with self._lock:
                return [self._status_buffer]
        if kind == RequestType.BLACKBOARD:
            return [blackboards_dump(payload.decode(errors="replace"), self.tree.main_id, self.tree.subtree_ports)]
        if kind == RequestType.HOOK_INSERT:
            for hook in parse_hooks(payload):
                bp.insert(hook)
            return []
        if kind == RequestType.HOOK_REMOVE:
            uid, position, _ = hook_target(payload)
            if not bp.remove(uid, position):
                raise ProtocolError("Node ID not found")
            return []
        if kind == RequestType.BREAKPOINT_UNLOCK:
            uid, position, data = hook_target(payload, "desired_status", "remove_when_done")
            if not bp.unlock(uid, position, str(data["desired_status"]), bool(data["remove_when_done"])):
                raise ProtocolError("Node ID not found")
            return []
        if kind == RequestType.REMOVE_ALL_HOOKS:
            bp.remove_all()
            return []
        if kind == RequestType.DISABLE_ALL_HOOKS:
            bp.enable_all(False)
            return []
        if kind == RequestType.HOOKS_DUMP:
            return [json.dumps(bp.dump()).encode()]  # JSON, as BT.CPP sends it
        if kind == RequestType.TOGGLE_RECORDING:
            return self._toggle_recording(payload)
        if kind == RequestType.GET_TRANSITIONS:
            with self._lock:
                taken = list(self._transitions)
                self._transitions.clear()
            return [encode_transitions(taken)]
        raise ProtocolError("Request not recognized")  # BREAKPOINT_REACHED: the server's to send

    def _toggle_recording(self, command: bytes) -> list[bytes]:
        with self._lock:
            if command == b"start":
                self._transitions.clear()
                self._recording_since = self.now()
                return [str(time.time_ns() // 1000).encode()]
            if command == b"stop":
                self._recording_since = None
        return []

    def close(self) -> None:
        """Stop serving: let a waiting tick go on, end the thread, free the ports."""
        self.breakpoints.remove_all()
        self._stop.set()
        self._thread.join(timeout=5)
        self._publisher.close()
        self._context.term()


NEEDS_PAYLOAD = {RequestType.BLACKBOARD, RequestType.HOOK_INSERT, RequestType.HOOK_REMOVE,
                 RequestType.BREAKPOINT_UNLOCK, RequestType.TOGGLE_RECORDING}

