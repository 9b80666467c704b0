"""The bytes of BehaviorTree.CPP's Groot2 monitor protocol (protocol 2), both ways.

Every exchange is a ZeroMQ multipart request and reply. A request's first part is a 6-byte header:
the protocol id (uint8, 2), the request type (one ASCII letter) and a request id (uint32,
little-endian); a reply's first part echoes that header and adds the tree's 16-byte id. What follows
depends on the type (see `RequestType`). A request the server cannot serve gets, instead of a reply
header, the two parts `error` and a message. Node statuses travel as 3 bytes per node (uid as a
little-endian uint16, then the status byte), recorded transitions as 9 bytes each (a 48-bit
microsecond time since recording started, the uid, the status). The status byte is BT.CPP's
`NodeStatus` (IDLE 0, RUNNING 1, SUCCESS 2, FAILURE 3, SKIPPED 4), or 10 + the last status for a node
idle again after it ran (what Groot2 shows faded).
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

PROTOCOL_ID = 2
HEADER = struct.Struct("<BBI")  # protocol, type, request id
UUID_SIZE = 16
IDLE_FROM = 10  # a status byte of 10 + S: idle now, S when it last ran


class ProtocolError(ValueError):
    """A message that is not what the protocol says."""


class RequestType(IntEnum):
    """BT.CPP's `BT::Monitor::RequestType`: what a request asks for."""

    FULLTREE = ord("T")  # -> the tree as XML, `_uid` on every node
    STATUS = ord("S")  # -> the status buffer
    BLACKBOARD = ord("B")  # part 2: blackboard names joined by ';' -> msgpack {name: {key: value}}
    HOOK_INSERT = ord("I")  # part 2: a hook or a list of hooks, JSON
    HOOK_REMOVE = ord("R")  # part 2: {"uid", "position"}
    BREAKPOINT_REACHED = ord("N")  # sent by the server on its PUB socket; part 2: the uid as text
    BREAKPOINT_UNLOCK = ord("U")  # part 2: {"uid", "position", "desired_status", "remove_when_done"}
    HOOKS_DUMP = ord("D")  # -> the hooks, JSON
    REMOVE_ALL_HOOKS = ord("A")
    DISABLE_ALL_HOOKS = ord("X")
    TOGGLE_RECORDING = ord("r")  # part 2: "start" (-> the wall time in us) or "stop"
    GET_TRANSITIONS = ord("t")  # -> the transitions recorded since the last call


class Status(IntEnum):
    """BT.CPP's `NodeStatus`."""

    IDLE = 0
    RUNNING = 1
    SUCCESS = 2
    FAILURE = 3
    SKIPPED = 4


@dataclass(frozen=True)
class Header:
    """A request header; a reply header is the same with the tree's id after it."""

    type: int
    request_id: int
    protocol: int = PROTOCOL_ID

    def encode(self) -> bytes:
        return HEADER.pack(self.protocol, self.type, self.request_id)

    @classmethod
    def decode(cls, data: bytes) -> Header:
        """The header of a request (exactly 6 bytes, as BT.CPP's server requires)."""
        if len(data) != HEADER.size:
            raise ProtocolError("wrong request header")
        protocol, kind, request_id = HEADER.unpack(data)
        return cls(kind, request_id, protocol)


def reply_header(request: Header, tree_id: bytes) -> bytes:
    """The first part of a reply: the request's header (with this protocol's id) and the tree id."""
    if len(tree_id) != UUID_SIZE:
        raise ValueError(f"a tree id is {UUID_SIZE} bytes, got {len(tree_id)}")
    return Header(request.type, request.request_id).encode() + tree_id


def error_reply(message: str) -> list[bytes]:
    """BT.CPP's error reply: `error` and the message."""
    return [b"error", message.encode()]


def encode_statuses(statuses: list[tuple[int, int]]) -> bytes:
    """The status buffer of (uid, status byte) pairs."""
    return b"".join(struct.pack("<HB", uid, status) for uid, status in statuses)


def decode_statuses(data: bytes) -> list[tuple[int, int]]:
    """(uid, status byte) pairs of a status buffer."""
    if len(data) % 3:
        raise ProtocolError(f"a status buffer is 3 bytes per node, got {len(data)} bytes")
    return [struct.unpack_from("<HB", data, i) for i in range(0, len(data), 3)]


def encode_transitions(transitions: list[tuple[int, int, int]]) -> bytes:
    """The transition buffer of (microseconds since recording started, uid, status) triples."""
    out = bytearray()
    for usec, uid, status in transitions:
        out += (usec & 0xFFFF_FFFF_FFFF).to_bytes(6, "little") + struct.pack("<HB", uid, status)
    return bytes(out)


def decode_transitions(data: bytes) -> list[tuple[int, int, int]]:
    """(microseconds, uid, status) triples of a transition buffer."""
    if len(data) % 9:
        raise ProtocolError(f"a transition buffer is 9 bytes per transition, got {len(data)} bytes")
    return [(int.from_bytes(data[i:i + 6], "little"), *struct.unpack_from("<HB", data, i + 6))
            for i in range(0, len(data), 9)]


class Position(IntEnum):
    """Where a hook acts: before the node ticks, or after."""

    PRE = 0
    POST = 1


class Mode(IntEnum):
    """A hook that waits for Groot2 to unlock it, or one that replaces the node's result at once."""

    BREAKPOINT = 0
    REPLACE = 1


@dataclass
class Hook:
    """A hook as Groot2 sends it (`HOOK_INSERT`) and lists it (`HOOKS_DUMP`)."""

    uid: int
    position: Position = Position.PRE
    mode: Mode = Mode.BREAKPOINT
    enabled: bool = True
    once: bool = False  # removed once it has fired
    desired_status: str = "SKIPPED"  # SUCCESS / FAILURE: the node's result; else the node runs

    @classmethod
    def from_json(cls, data: Any) -> Hook:
        """A hook from its JSON object; ProtocolError naming a missing or bad field."""
        if not isinstance(data, dict):
            raise ProtocolError(f"a hook is a JSON object, got {type(data).__name__}")
        try:
            return cls(uid=_uid(data["uid"]), position=Position(int(data["position"])), mode=Mode(int(data["mode"])),
                       enabled=bool(data["enabled"]), once=bool(data["once"]),
                       desired_status=_status_name(data["desired_status"]))
        except KeyError as exc:
            raise ProtocolError(f"a hook needs the field {exc.args[0]!r}") from None
        except (TypeError, ValueError) as exc:
            raise ProtocolError(f"bad hook: {exc}") from None

    def to_json(self) -> dict:
        return {"enabled": self.enabled, "uid": self.uid, "mode": int(self.mode), "once": self.once,
                "desired_status": self.desired_status, "position": int(self.position)}


def parse_hooks(payload: bytes) -> list[Hook]:
    """The hooks of a `HOOK_INSERT` request: one JSON hook, or a list of them."""
    data = parse_json(payload)
    return [Hook.from_json(h) for h in (data if isinstance(data, list) else [data])]


def parse_json(payload: bytes) -> Any:
    try:
        return json.loads(payload)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ProtocolError(f"not JSON: {exc}") from None


def hook_target(payload: bytes, *fields: str) -> tuple[int, Position, dict]:
    """The uid and position a `HOOK_REMOVE` or `BREAKPOINT_UNLOCK` names, and the whole object."""
    data = parse_json(payload)
    if not isinstance(data, dict):
        raise ProtocolError("expected a JSON object")
    missing = [f for f in ("uid", "position", *fields) if f not in data]
    if missing:
        raise ProtocolError(f"missing field {missing[0]!r}")
    try:
        return _uid(data["uid"]), Position(int(data["position"])), data
    except (TypeError, ValueError) as exc:
        raise ProtocolError(f"bad field: {exc}") from None


def _uid(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFF:
        raise ValueError(f"uid must be an integer 0..65535, got {value!r}")
    return value


def _status_name(value: Any) -> str:
    if not isinstance(value, str):
        raise TypeError(f"desired_status must be a status name, got {value!r}")
    return value if value in ("SUCCESS", "FAILURE") else "SKIPPED"
