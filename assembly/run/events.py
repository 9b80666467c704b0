"""Where a run's events go: the design bridge of a run that builds a design (its as-built records
and the run's own events in one log), else a `RunEvents` log of the run's own events (start,
halts, crashes, end). Either way every run with a run directory writes `events.jsonl`, each
record appended and forced to disk, stamped with the wall `time` and the run's tick, cell time
`t` and element in work."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from fvfiles.json_files import append_json_line_or_stderr


class EventSink(Protocol):
    """What the run logs its events to (`DesignBridge` and `RunEvents` both are one)."""

    stamp: Callable[[], dict] | None  # the run's {tick, t, element} now (the tick loop sets it)
    unlogged: int  # events that went to stderr: the event log could not be written

    def event(self, kind: str, **data: Any) -> bool:
        """Log an event; whether it reached the log."""
        ...


class RunEvents:
    """The event log of a run with no design: the same records and schema as a design run's log
    (`{time, event, ..., tick, t, element}`), without the as-built records, so that the MCAP export,
    the recorder and a reader of the run directory find every run's events in one place. A record
    the log cannot take goes to stderr (`unlogged` counts them), as the design bridge's do."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.stamp: Callable[[], dict] | None = None
        self.unlogged = 0

    def event(self, kind: str, **data: Any) -> bool:
        """Append `kind` with `data`, the wall time and the run's stamp (data wins over the stamp)."""
        stamp = self.stamp() if self.stamp is not None else {}
        record = {"time": time.time(), "event": kind, **data, **{k: v for k, v in stamp.items() if k not in data}}
        logged = append_json_line_or_stderr(self.path, record)
        self.unlogged += not logged
        return logged
