"""The lock of a run directory: one `fvtree run` (a new run or a resumed one) at a time may write
it, so two resumes of one run cannot both build the element left to build.

The lock is an advisory `flock` on `run_dir/.lock`, held for the whole session: the kernel drops
it when the process ends, even by kill -9, so a crashed run never leaves a stale lock behind. The
file holds the pid of its holder, for the error message only."""

from __future__ import annotations

import errno
import fcntl
import os
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING

from fvfiles.errors import FvtreeError

if TYPE_CHECKING:
    from typing_extensions import Self  # typing.Self from Python 3.11

LOCK_FILE = ".lock"


class RunDirBusy(FvtreeError):
    """Another process holds the run directory's lock; exit code 2."""


class RunLock:
    """An exclusive, non-blocking lock on a run directory (`acquire` raises `RunDirBusy` when
    another process holds it); `release` (or leaving a `with` block) frees it."""

    def __init__(self, run_dir: Path):
        self.path = Path(run_dir) / LOCK_FILE
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def acquire(self) -> Self:
        """Take the lock now or refuse: a second session of a run never waits for the first."""
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = _holder(fd)
            os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise RunDirBusy(f"another fvtree run{f' (pid {holder})' if holder else ''} is using this run "
                                 "directory", str(self.path.parent),
                                 hint="wait for it to end, or stop it (Ctrl-C, or create the ESTOP file in the "
                                      "run directory) before resuming") from None
            raise
        try:  # who holds it, for the message a second session prints (best effort: a full disk may refuse)
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
        except OSError:
            pass
        self._fd = fd
        return self

    def release(self) -> None:
        """Free the lock (closing the file releases the flock); idempotent."""
        if self._fd is not None:
            fd, self._fd = self._fd, None
            os.close(fd)

    def __enter__(self) -> Self:
        return self.acquire()

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.release()


def _holder(fd: int) -> str:
    """The pid the lock file names, or "" (unreadable, or being written)."""
    try:
        text = os.pread(fd, 32, 0).decode(errors="replace").strip()
    except OSError:
        return ""
    return text if text.isdigit() else ""
