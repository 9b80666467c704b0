"""The recording of a run, kept from ending the run: a recording that cannot be written (a full
disk, a file-size limit: Rerun's file writer then shuts down and its next flush raises) stops,
says so in the summary, and the run goes on; so does a recording on a disk about to fill, or near
the file-size limit, before it takes the room the as-built records need (`RunStorage.shortage`).
Under such a shortage the recording does not start at all (`guarded_recorder`): Rerun's
`set_sinks` waits forever for a file writer that failed its first write."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import py_trees

from assembly.observe.recorder import RunRecorder
from assembly.run.storage import RunStorage

CHECK_EVERY = 30  # ticks between two looks at the free space (a statvfs: microseconds)


class GuardedRecorder:
    """A `RunRecorder` behind a guard (the tick loop's `Recorder`): the first exception it raises,
    or too little free space, stops it for the rest of the run and is noted in `storage`."""

    def __init__(self, recorder: RunRecorder, storage: RunStorage):
        self.recorder: RunRecorder | None = recorder
        self.storage = storage
        self.what = recorder.path.name if recorder.path else "the live view"  # its name in the summary
        self._tick = 0
        self._size = 0  # the recording file's size at the last look
        self._step = 0  # the most it grew between two looks (a batch of ticks is written at once)

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        self.record(tree.count)

    def record(self, tick: int) -> None:
        self._tick = tick
        if self.recorder is not None and tick % CHECK_EVERY == 0:
            short = self.storage.shortage(self.recorder.path, 2 * self._grown())
            if short is not None:
                # Ends the file with what was sent: the batch not yet sent (as large as the margin) is dropped.
                self.recorder.stream.disconnect()
                self._stop(short)
                return
        self._guarded("record", tick)

    def _grown(self) -> int:
        """The most the recording file grew between two looks so far."""
        path = self.recorder.path if self.recorder is not None else None
        try:
            size = path.stat().st_size if path is not None else 0
        except OSError:
            size = self._size
        self._step, self._size = max(self._step, size - self._size), size
        return self._step

    def event(self, kind: str, **data: Any) -> None:
        self._guarded("event", kind, **data)

    def close(self) -> None:
        self._guarded("close")

    def finish(self) -> None:
        self._guarded("finish")

    def _guarded(self, method: str, *args: Any, **kwargs: Any) -> None:
        if self.recorder is None:
            return
        try:
            getattr(self.recorder, method)(*args, **kwargs)
        except (OSError, RuntimeError) as exc:  # RuntimeError: Rerun's file writer has shut down
            self._stop(exc)  # noticed at a flush, some ticks after the writer stopped

    def _stop(self, exc: BaseException | str) -> None:
        """Note the loss, then end the recording as far as it still goes."""
        recorder, self.recorder = self.recorder, None
        self.storage.lost(self.what, exc, since=f"tick {self._tick}" if self._tick else "")
        try:
            if recorder is not None:
                recorder.finish()
        except (OSError, RuntimeError):
            pass


def guarded_recorder(storage: RunStorage, path: Path | None, make: Callable[[], RunRecorder]) -> GuardedRecorder | None:
    """The recorder `make` builds, guarded; None (and the reason noted) when a recording to `path`
    should not start for lack of room."""
    short = storage.shortage(path) if path is not None else None
    if short is not None and path is not None:
        storage.lost(path.name, short)
        return None
    return GuardedRecorder(make(), storage)
