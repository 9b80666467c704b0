"""A Groot2 client for the tests, written from BehaviorTree.CPP's protocol description
(`groot2_protocol.h`, `groot2_publisher.cpp`: protocol 2), not from fvtree's server: it shares no
code with `assembly.interop.groot2`.

Request: multipart; part 1 is `<B protocol=2><B type><I request id>` (little-endian), part 2 the
payload if any. Reply: part 1 echoes the 6 bytes and adds the tree's 16-byte id; or the parts
`error` and a message. Status buffer: `<H uid><B status>` per node; transitions: 6-byte
microseconds, `<H uid><B status>`. Breakpoints reached are announced on the PUB socket (port + 1)
as `[header of type 'N', uid as text]`."""

from __future__ import annotations

import random
import struct
import time

import zmq

TIMEOUT_MS = 60_000  # generous: the server answers from its own thread, but the machine may be loaded


class ServerError(Exception):
    """The server answered `error` with this message."""


class Client:
    """REQ client (and, on demand, a SUB socket for breakpoint notifications)."""

    def __init__(self, port: int, host: str = "127.0.0.1"):
        self.port = port
        self.context = zmq.Context()
        self.req = self.context.socket(zmq.REQ)
        self.req.setsockopt(zmq.RCVTIMEO, TIMEOUT_MS)
        self.req.setsockopt(zmq.SNDTIMEO, TIMEOUT_MS)
        self.req.setsockopt(zmq.LINGER, 0)
        self.req.connect(f"tcp://{host}:{port}")
        self.sub = self.context.socket(zmq.SUB)
        self.sub.setsockopt(zmq.LINGER, 0)
        self.sub.setsockopt(zmq.SUBSCRIBE, b"")
        self.sub.connect(f"tcp://{host}:{port + 1}")
        self.tree_id: bytes | None = None

    def raw(self, frames: list[bytes]) -> list[bytes]:
        self.req.send_multipart(frames)
        return self.req.recv_multipart()

    def request(self, kind: str, payload: bytes | None = None) -> list[bytes]:
        """Send a request of type `kind` (one letter); the reply's parts after the header."""
        request_id = random.getrandbits(32)
        header = struct.pack("<BBI", 2, ord(kind), request_id)
        reply = self.raw([header] + ([payload] if payload is not None else []))
        if reply[0] == b"error":
            raise ServerError(reply[1].decode())
        assert len(reply[0]) == 22, reply[0]
        protocol, echoed, echoed_id = struct.unpack("<BBI", reply[0][:6])
        assert (protocol, echoed, echoed_id) == (2, ord(kind), request_id)
        self.tree_id = reply[0][6:]
        return reply[1:]

    def full_tree(self) -> str:
        return self.request("T")[0].decode()

    def statuses(self) -> dict[int, int]:
        data = self.request("S")[0]
        assert len(data) % 3 == 0
        return {struct.unpack_from("<H", data, i)[0]: data[i + 2] for i in range(0, len(data), 3)}

    def blackboards(self, *names: str) -> bytes:
        return self.request("B", ";".join(names).encode())[0]

    def start_recording(self) -> int:
        return int(self.request("r", b"start")[0])

    def stop_recording(self) -> None:
        self.request("r", b"stop")

    def transitions(self) -> list[tuple[int, int, int]]:
        data = self.request("t")[0]
        assert len(data) % 9 == 0
        return [(int.from_bytes(data[i:i + 6], "little"), struct.unpack_from("<H", data, i + 6)[0], data[i + 8])
                for i in range(0, len(data), 9)]

    def breakpoint_reached(self, timeout: float = 120.0) -> int:
        """Wait for a breakpoint notification (asking for statuses meanwhile, the heartbeat that
        keeps the server's hooks enabled); the node's uid."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.sub.poll(200):
                header, uid = self.sub.recv_multipart()
                protocol, kind, _ = struct.unpack("<BBI", header)
                assert (protocol, kind) == (2, ord("N"))
                return int(uid)
            self.statuses()
        raise TimeoutError("no breakpoint reached")

    def close(self) -> None:
        self.context.destroy(linger=0)
