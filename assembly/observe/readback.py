"""Reading a recording back: each entity's rows with their tick and cell time, for tests, the
recording bench and anyone checking what a run recorded."""

from __future__ import annotations

import warnings
from collections import defaultdict
from pathlib import Path
from typing import Any

import pyarrow as pa
from rerun.chunk import RrdReader

from perception.errors import FvtreeError


def read_recording(path: str | Path) -> dict[str, list[dict[str, Any]]]:
    """Entity path (without the leading `/`) -> its rows sorted by tick: `tick` (None for static
    data), `cell_time` (s) and each component by its column name (`Scalars:scalars`, `status`,
    ...), as Python lists. A recording cut short (a killed run) reads up to its last whole chunk."""
    try:
        with warnings.catch_warnings():  # a killed run's file has no footer: it is read whole, as wanted
            warnings.filterwarnings("ignore", message="RRD file has no footer")
            chunks = RrdReader(Path(path)).stream().to_chunks()
    except (OSError, ValueError, RuntimeError) as exc:  # RuntimeError: Rerun's reader on a file that is no recording
        raise FvtreeError(f"not a readable recording ({exc})", str(path),
                          hint="open a run directory that `fvtree run` made, under runs/") from None
    rows: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for chunk in chunks:
        batch = chunk.to_record_batch()
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
            rows[chunk.entity_path.lstrip("/")].append(row)
    for entity_rows in rows.values():
        entity_rows.sort(key=lambda r: -1 if r["tick"] is None else r["tick"])
    return dict(rows)
