"""Where a run's events go: the design bridge of a run that builds a design (its as-built records
and the run's own events in one log), else an `EventLog` (`fvfiles.json_files`) of the run's own events
(start, halts, crashes, end). Either way every run with a run directory writes `events.jsonl`, each
record appended and forced to disk, stamped with the wall `time` and the run's tick, cell time
`t` and element in work."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol


class EventSink(Protocol):
    """What the run logs its events to (`DesignBridge` and `fvfiles.json_files.EventLog` both are one)."""

    stamp: Callable[[], dict] | None  # the run's {tick, t, element} now (the tick loop sets it)
    unlogged: int  # events that went to stderr: the event log could not be written

    def event(self, kind: str, **data: Any) -> bool:
        """Log an event; whether it reached the log."""
        ...
