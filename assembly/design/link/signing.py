"""Signatures on what a cell and the coordinator must trust end to end, whatever the broker lets
through: a cell's requests (claim, renew, placing, placed, failed), the coordinator's answers to
it, and the coordinator's plan. Each cell shares a secret with the coordinator (its credentials
file: `secret`; the coordinator's: `cells`), and a message is signed with HMAC-SHA256 over its
canonical JSON (keys sorted, no spaces) with that secret, so another client, even one with an
account on the broker, can neither forge nor alter one; a request or answer echoes the cell's
name and a request id, so a message meant for one cell does not pass for another's, and a replay
is refused as a request id seen before.

A plan carries one signature per cell (`signatures`, beside compas_eve's `dtype` and `data`, which
compas_eve ignores), over its `data`."""

from __future__ import annotations

import hashlib
import hmac
import json
from typing import Any

SIG = "sig"  # the field of a signed request or answer


class SignatureError(ValueError):
    """A message that is not signed, or not by whom it says."""


def canonical(data: Any) -> bytes:
    """The bytes a signature covers (NaN and infinities are not JSON: refused)."""
    return json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False, ensure_ascii=True).encode()


def signature(secret: bytes, data: Any) -> str:
    return hmac.new(secret, canonical(data), hashlib.sha256).hexdigest()


def sign(secret: bytes, message: dict) -> dict:
    """The message with its signature."""
    body = {k: v for k, v in message.items() if k != SIG}
    return {**body, SIG: signature(secret, body)}


def verify(secret: bytes, message: dict) -> dict:
    """The message without its signature, if the signature is right; else SignatureError."""
    given = message.get(SIG)
    if not isinstance(given, str):
        raise SignatureError("not signed")
    body = {k: v for k, v in message.items() if k != SIG}
    try:
        expected = signature(secret, body)
    except ValueError:
        raise SignatureError("cannot be signed (not plain JSON)") from None
    if not hmac.compare_digest(given, expected):
        raise SignatureError("bad signature (not from whom it names, or altered)")
    return body


def sign_plan(encoded: bytes | str, secrets: dict[str, bytes]) -> bytes:
    """A compas_eve-encoded plan ({"dtype", "data", ...}) with each cell's signature of its data."""
    message = json.loads(encoded)
    message["signatures"] = {cell: signature(secret, message["data"]) for cell, secret in secrets.items()}
    return json.dumps(message).encode()


def verify_plan(message: dict, cell: str, secret: bytes) -> None:
    """SignatureError unless the plan carries `cell`'s right signature of its data."""
    sigs = message.get("signatures")
    given = sigs.get(cell) if isinstance(sigs, dict) else None
    if not isinstance(given, str):
        raise SignatureError(f"plan not signed for {cell}")
    try:
        expected = signature(secret, message.get("data"))
    except ValueError:
        raise SignatureError("plan cannot be signed (not plain JSON)") from None
    if not hmac.compare_digest(given, expected):
        raise SignatureError(f"bad signature on the plan for {cell}")
