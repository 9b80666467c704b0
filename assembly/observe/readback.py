"""Reading a recording back: each entity's rows with their tick and cell time, for tests, the
recording bench and anyone checking what a run recorded."""

from __future__ import annotations

import os
import tempfile
import warnings
from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pyarrow as pa
from rerun.chunk import RrdReader

from fvfiles.errors import FvtreeError

RRD_MAGIC, RRD_HEADER, MESSAGE_HEADER = b"RRF2", 12, 16


def read_recording(path: str | Path, entities: Iterable[str] | None = None) -> dict[str, list[dict[str, Any]]]:
    """Entity path (without the leading `/`) -> its rows sorted by tick: `tick` (None for static
    data), `cell_time` (s) and each component by its column name (`Scalars:scalars`, `status`,
    ...), as Python lists. `entities`: only these entity paths (e.g. `["tree/status", "events"]`),
    read a chunk at a time, so that memory grows with what they hold and not with the whole run.
    A recording cut short (a killed run) reads up to its last whole chunk."""
    try:
        rows = _read(Path(path), entities)
    except RuntimeError as exc:  # Rerun's reader on a file that is no recording, or one whose last message is cut
        whole = _whole_messages(Path(path))
        if whole is None:
            raise FvtreeError(f"not a readable recording ({exc})", str(path),
                              hint="open a run directory that `fvtree run` made, under runs/") from None
        with tempfile.TemporaryDirectory() as tmp:  # a run killed while writing: its messages up to the cut one
            cut = Path(tmp) / "recording.rrd"
            with open(path, "rb") as f:
                cut.write_bytes(f.read(whole))
            rows = _read(cut, entities)
    except (OSError, ValueError) as exc:
        raise FvtreeError(f"not a readable recording ({exc})", str(path),
                          hint="open a run directory that `fvtree run` made, under runs/") from None
    for entity_rows in rows.values():
        entity_rows.sort(key=lambda r: -1 if r["tick"] is None else r["tick"])
    return dict(rows)


def _read(path: Path, entities: Iterable[str] | None) -> dict[str, list[dict[str, Any]]]:
    rows: dict[str, list[dict[str, Any]]] = defaultdict(list)
    with warnings.catch_warnings():  # a killed run's file has no footer: it is read whole, as wanted
        warnings.filterwarnings("ignore", message="RRD file has no footer")
        stream = RrdReader(path).stream()
        if entities is not None:
            stream = stream.filter(content=[f"+ /{e.strip('/')}" for e in entities] or ["- /**"])
        for chunk in stream:
            _add_rows(rows[chunk.entity_path.lstrip("/")], chunk.to_record_batch())
    return rows


def _whole_messages(path: Path) -> int | None:
    """The length of the file's leading whole messages when its last one is cut (a run killed while a
    batch was written), else None. An .rrd file is a 12-byte header (`RRF2`, version, options), then
    messages of a 16-byte header (kind, payload length: little-endian u64) and the payload."""
    with open(path, "rb") as f:
        if f.read(4) != RRD_MAGIC:
            return None
        size, end = os.fstat(f.fileno()).st_size, RRD_HEADER
        while end + MESSAGE_HEADER <= size:
            f.seek(end + 8)
            length = int.from_bytes(f.read(8), "little")
            if end + MESSAGE_HEADER + length > size:
                return end
            end += MESSAGE_HEADER + length
    return end if end < size else None


def _add_rows(rows: list[dict[str, Any]], batch: pa.RecordBatch) -> None:
    """The rows of one chunk, times in seconds."""
    columns = {}
    for name, column in zip(batch.schema.names, batch.columns):
        if name == "rerun.controls.RowId":
            continue
        if pa.types.is_duration(column.type) or pa.types.is_timestamp(column.type):
            columns[name] = [None if v is None else v / 1e9 for v in column.cast(pa.int64()).to_pylist()]
        else:
            columns[name] = column.to_pylist()
    for i in range(batch.num_rows):
        row = {name: values[i] for name, values in columns.items()}
        row.setdefault("tick", None)
        rows.append(row)
