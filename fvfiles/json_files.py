"""Run files: JSON for numpy values, atomic replacement, and appended lines that reach the disk."""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np


def to_jsonable(value: Any) -> Any:
    """`json.dumps(default=...)` hook: numpy arrays and scalars as plain lists and numbers."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot store {type(value).__name__} as JSON")


def atomic_write_json(path: Path, data: Any) -> None:
    """Write JSON so that readers see the old file or the new one, never a torn one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1, default=to_jsonable)
            f.write("\n")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def append_json_line(path: Path, record: dict) -> None:
    """Append one JSON line and force it to disk (event logs survive a crash). A write that fails
    part way (a full disk, the file-size limit) is cut back off, so that a later line never
    follows a torn one."""
    data = (json.dumps(record, default=to_jsonable) + "\n").encode()
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        size = os.fstat(fd).st_size
        try:
            done = 0
            while done < len(data):
                done += os.write(fd, data[done:])
            os.fsync(fd)
        except OSError:
            try:
                os.ftruncate(fd, size)
            except OSError:
                pass
            raise
    finally:
        os.close(fd)


def append_json_line_or_stderr(path: Path, record: dict) -> bool:
    """Append one JSON line to `path`, or, when that fails, write it to stderr so that it is not
    lost; returns whether it reached the file."""
    try:
        append_json_line(path, record)
        return True
    except OSError as exc:
        sys.stderr.write(f"cannot append to {path} ({exc.strerror or exc}); the record: "
                         + json.dumps(record, default=to_jsonable) + "\n")
        sys.stderr.flush()
        return False


class EventLog:
    """An append-only JSON-lines log of events, each record forced to disk (or to stderr when the
    file cannot take it: `unlogged` counts those) and stamped with the wall `time` and whatever
    `stamp` returns now (a run's tick, cell time and element in work; the record's own data wins)."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.stamp: Callable[[], dict] | None = None
        self.unlogged = 0

    def stamped(self, kind: str, data: dict) -> dict:
        """The record of event `kind` with `data`, stamped."""
        stamp = self.stamp() if self.stamp is not None else {}
        return {"time": time.time(), "event": kind, **data, **{k: v for k, v in stamp.items() if k not in data}}

    def write(self, record: dict) -> bool:
        """Append `record`; whether it reached the log."""
        logged = append_json_line_or_stderr(self.path, record)
        self.unlogged += not logged
        return logged

    def event(self, kind: str, **data: Any) -> bool:
        """Log event `kind` with `data`; whether it reached the log."""
        return self.write(self.stamped(kind, data))


def read_json_lines(path: Path) -> list[dict]:
    """The records of a JSON-lines file (none if it is missing), skipping a line torn by a crash."""
    records: list[dict] = []
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        return records
    for line in text.splitlines():
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(record, dict):
            records.append(record)
    return records
