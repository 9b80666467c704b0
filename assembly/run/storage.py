"""Disk trouble in a run directory, as errors a person acts on: a full disk (ENOSPC), a quota
(EDQUOT) or a file-size limit (EFBIG, `ulimit -f`; the SIGXFSZ that would kill the process is
ignored by the command line so that the write raises instead), a read-only or forbidden place."""

from __future__ import annotations

import errno
import os
import resource
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from fvfiles.errors import DISK_FULL, FvtreeError

CANNOT_WRITE = DISK_FULL | {errno.EROFS, errno.EACCES, errno.EPERM}
HINT = "free some disk space (df -h), raise the file-size limit (ulimit -f), or give another --runs-dir"


def is_disk_full(exc: BaseException) -> bool:
    """Whether `exc` says the disk, a quota or the file-size limit has no room left."""
    return isinstance(exc, OSError) and exc.errno in DISK_FULL


def why(exc: OSError) -> str:
    """The reason of an OSError in a few words, with its errno name (e.g. `No space left on device (ENOSPC)`)."""
    name = errno.errorcode.get(exc.errno or 0)
    return f"{exc.strerror or exc}" + (f" ({name})" if name else "")


class StorageError(FvtreeError):
    """A file of the run could not be written for lack of room or permission; exit code 2."""

    @classmethod
    def of(cls, exc: OSError, where: Path | str, what: str = "cannot write the run directory") -> StorageError:
        return cls(f"{what}: {why(exc)}", str(exc.filename or where), hint=HINT)


@contextmanager
def storage_errors_located(where: Path | str) -> Iterator[None]:
    """Turn a failed write under `where` (no room, read-only, forbidden) into a located StorageError."""
    try:
        yield
    except OSError as exc:
        if exc.errno not in CANNOT_WRITE:
            raise
        raise StorageError.of(exc, where) from None


RESERVE_FILE = ".reserve"
RESERVE_BYTES = 1 << 20  # room kept for the as-built records (about 2 kB each) once the disk fills
LOW_SPACE_BYTES = 64 << 20  # below this much free space the recording stops, before it fills the disk
MIN_LIMIT = 256 << 10  # under a file-size limit this low the recording does not start


class RunStorage:
    """What a run may lose to disk trouble, and the room kept for what it may not.

    The as-built records (`events.jsonl`, `asbuilt.json`) come first: a reserve file of
    `RESERVE_BYTES` is set aside when the run starts and given back the first time a write finds
    the disk full, so that they still fit. The recording and the transition log come after: they
    stop at their first failed write (`lost`), and the recording also stops (or never starts) as
    soon as the disk has less than `low_space` bytes free or it nears the file-size limit
    (`shortage`). `notes` says what was lost, for the summary."""

    def __init__(self, run_dir: Path | None, reserve: int = RESERVE_BYTES, low_space: int | None = None):
        self.run_dir = run_dir
        self.low_space = LOW_SPACE_BYTES if low_space is None else low_space
        self.notes: list[str] = []
        self._reserve: Path | None = None
        if run_dir is not None and reserve > 0:
            self._reserve = run_dir / RESERVE_FILE
            try:
                fd = os.open(self._reserve, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o600)
                try:
                    os.posix_fallocate(fd, 0, reserve)  # blocks allocated now, not when written
                finally:
                    os.close(fd)
            except OSError:  # already short of room (or a file system without fallocate): no reserve
                self.release()

    def lost(self, what: str, exc: BaseException | str, since: str = "") -> None:
        """`what` stopped being written because of `exc` (or the reason given; `since`: from when);
        a full disk gives back the reserve, for the as-built records."""
        reason = (exc if isinstance(exc, str) else why(exc) if isinstance(exc, OSError)
                  else f"{type(exc).__name__}: {exc}")
        self.notes.append(f"{what}: not written{f' from {since}' if since else ''} ({reason})")
        if not isinstance(exc, str) and (is_disk_full(exc) or "shut down" in str(exc)):  # rerun's writer stops so
            self.release()

    def shortage(self, growing: Path | None = None, step: int = 0) -> str | None:
        """Why a file that may grow large (`growing`: the recording, by up to `step` bytes at a
        time) should stop, or not start: fewer than `low_space` (+ `step`) bytes free under the run
        directory, or the file within a quarter of the file-size limit (`ulimit -f`) of the
        process, or within `step` of it (None: room enough)."""
        if self.run_dir is None:
            return None
        try:
            stat = os.statvfs(self.run_dir)
        except OSError:
            return None
        free = stat.f_bavail * stat.f_frsize
        if free < self.low_space + step:
            return f"only {free >> 20} MiB free on the disk, kept for the as-built records"
        limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
        if limit != resource.RLIM_INFINITY and growing is not None:
            try:
                size = growing.stat().st_size
            except OSError:
                size = 0
            if size + max(limit // 4, step) >= limit or limit < MIN_LIMIT:
                return f"the file-size limit (ulimit -f) is {limit >> 10} KiB"
        return None

    def release(self) -> None:
        """Give the reserve back to the disk (once; also when the run ends)."""
        if self._reserve is not None:
            path, self._reserve = self._reserve, None
            path.unlink(missing_ok=True)
