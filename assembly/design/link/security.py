"""Who the design link logs in as, how it reaches the broker, and the secrets it signs with.

Credentials come from a credentials file (JSON, readable by its owner only, like an ssh key) or
from the environment, never from the broker URL (a URL is shown in logs, summaries and process
lists): `mqtt://user:pass@host` is refused. The password and the secrets are never printed (they
are left out of `repr`). A credentials file holds any of:

    {"username": "A", "password": "...",             # the broker login (mosquitto password file)
     "ca": "ca.crt", "cert": "a.crt", "key": "a.key",  # TLS: the CA to trust, and a client certificate
     "secret": "64 hex digits",                        # a cell: the secret it shares with the coordinator
     "cells": {"A": "hex", "B": "hex"}}                # the coordinator: every cell's secret

Relative paths are read from the file's folder. The environment gives FVTREE_MQTT_USERNAME,
FVTREE_MQTT_PASSWORD and FVTREE_LINK_SECRET (a cell's secret); a file's values come first.
Signing (`assembly.design.link.signing`) is on when a secret is given."""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from assembly.errors import TreeError

ENV_USERNAME, ENV_PASSWORD, ENV_SECRET = "FVTREE_MQTT_USERNAME", "FVTREE_MQTT_PASSWORD", "FVTREE_LINK_SECRET"
FIELDS = ("username", "password", "ca", "cert", "key", "secret", "cells")
SCHEMES = {"mqtt": 1883, "mqtts": 8883}
MIN_SECRET_BYTES = 16
LOST_AFTER = 10.0  # s: a link lost longer than this is a fault (a coordinated cell's lease is 10 s)


class LinkError(TreeError):
    """The design link cannot be set up or was lost: bad address or credentials, a broker that
    refuses or cannot be reached (exit code 2 before a run; a FAULT during one)."""


@dataclass(frozen=True)
class Broker:
    """Where the broker is: host, port and whether to speak TLS (mqtts://)."""

    host: str
    port: int
    tls: bool

    def __str__(self) -> str:
        return f"{'mqtts' if self.tls else 'mqtt'}://{self.host}:{self.port}"


def parse_broker_url(url: str, option: str = "--bridge") -> Broker:
    """The broker of mqtt://HOST[:PORT] (1883) or mqtts://HOST[:PORT] (8883, TLS). A URL with a
    user or password is refused without repeating it (it would end up in logs)."""
    parts = urlsplit(url)
    if parts.username is not None or parts.password is not None:
        raise LinkError("a broker address must not hold a user name or password", option,
                        hint=f"give them in a credentials file (--credentials) or in {ENV_USERNAME} and "
                             f"{ENV_PASSWORD}; the address is shown in logs")
    try:
        port = parts.port or SCHEMES.get(parts.scheme)
    except ValueError:
        port = None
    if parts.scheme not in SCHEMES or not parts.hostname or port is None or parts.path not in ("", "/"):
        raise LinkError(f"bad broker address {url!r}", option,
                        hint="write mqtt://HOST:PORT or mqtts://HOST:PORT, e.g. mqtt://127.0.0.1:1883")
    return Broker(parts.hostname, port, parts.scheme == "mqtts")


@dataclass(frozen=True)
class LinkSecurity:
    """The login, TLS files and signing secrets of one link end (see the module docstring)."""

    username: str | None = None
    password: str | None = field(default=None, repr=False)
    ca: Path | None = None
    cert: Path | None = None
    key: Path | None = None
    secret: bytes | None = field(default=None, repr=False)
    cells: Mapping[str, bytes] = field(default_factory=dict, repr=False)
    lost_after: float = LOST_AFTER

    @property
    def tls_files(self) -> bool:
        return any(p is not None for p in (self.ca, self.cert, self.key))

    def tls_options(self) -> dict[str, Any]:
        """paho's `tls_set` arguments (compas_eve's `tls_options`): the CA (else the system's), and
        the client certificate and key when given."""
        return {"ca_certs": _str(self.ca), "certfile": _str(self.cert), "keyfile": _str(self.key)}

    @classmethod
    def load(cls, credentials: str | Path | None = None, env: Mapping[str, str] | None = None,
             ca: str | Path | None = None, cert: str | Path | None = None, key: str | Path | None = None,
             lost_after: float = LOST_AFTER) -> LinkSecurity:
        """From a credentials file (if given), then the environment, then the TLS options; checked."""
        env = os.environ if env is None else env
        data: dict[str, Any] = {}
        where = "--credentials"
        if credentials is not None:
            where = str(credentials)
            data = _read_file(Path(credentials))
        base = Path(credentials).parent if credentials is not None else Path.cwd()
        files = {name: _file(data.get(name), base, where, name) for name in ("ca", "cert", "key")}
        for name, given in (("ca", ca), ("cert", cert), ("key", key)):
            if given is not None:
                files[name] = _file(given, Path.cwd(), f"--tls-{name}", name)
        if (files["cert"] is None) != (files["key"] is None):
            raise LinkError("a client certificate needs its key, and a key its certificate", where,
                            hint="give both cert and key (--tls-cert and --tls-key)")
        username = data.get("username", env.get(ENV_USERNAME))
        password = data.get("password", env.get(ENV_PASSWORD))
        if password is not None and username is None:
            raise LinkError("a password without a user name", where, hint=f"set username (or {ENV_USERNAME})")
        for name, value in (("username", username), ("password", password)):
            if value is not None and (not isinstance(value, str) or not value):
                raise LinkError(f"{name} must be a non-empty string", where, hint=None)
        secret = _secret(data.get("secret", env.get(ENV_SECRET)), where, "secret")
        cells = data.get("cells", {})
        if not isinstance(cells, dict) or None in cells.values():
            raise LinkError("field 'cells' must map each cell's name to its secret", where)
        return cls(username, password, files["ca"], files["cert"], files["key"], secret,
                   {str(c): _cell_secret(s, where, str(c)) for c, s in cells.items()}, lost_after)


def _str(path: Path | None) -> str | None:
    return None if path is None else str(path)


def _read_file(path: Path) -> dict[str, Any]:
    try:
        mode = path.stat().st_mode
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise LinkError(f"cannot read the credentials file ({exc.strerror or exc})", str(path)) from None
    if mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise LinkError("the credentials file is readable by others", str(path),
                        hint=f"chmod 600 {path} (it holds passwords and secrets)")
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise LinkError(f"not JSON: {exc.args[0].split(':')[0]}", str(path)) from None  # no text of the file
    if not isinstance(data, dict):
        raise LinkError("a credentials file is a JSON object", str(path))
    unknown = sorted(set(data) - set(FIELDS))
    if unknown:
        raise LinkError(f"unknown field(s) {', '.join(unknown)}", str(path), hint=f"known: {', '.join(FIELDS)}")
    return data


def _file(value: Any, base: Path, where: str, name: str) -> Path | None:
    if value is None:
        return None
    if not isinstance(value, (str, Path)) or not str(value):
        raise LinkError(f"{name} must be a file path", where)
    path = base / value
    if not path.is_file():
        raise LinkError(f"{name}: no file {path}", where)
    return path


def _cell_secret(value: Any, where: str, cell: str) -> bytes:
    secret = _secret(value, where, f"cells.{cell}")
    if secret is None:
        raise LinkError(f"cells.{cell}: no secret", where)
    return secret


def _secret(value: Any, where: str, name: str) -> bytes | None:
    """A signing secret given as hex (at least MIN_SECRET_BYTES bytes); the value is never shown."""
    if value is None:
        return None
    try:
        secret = bytes.fromhex(value) if isinstance(value, str) else b""
    except ValueError:
        secret = b""
    if len(secret) < MIN_SECRET_BYTES:
        raise LinkError(f"{name} must be at least {MIN_SECRET_BYTES} bytes in hex", where,
                        hint="make one with: python -c 'import secrets; print(secrets.token_hex(32))'")
    return secret
