"""Disk trouble in a run directory, as errors a person acts on: a full disk (ENOSPC), a quota
(EDQUOT) or a file-size limit (EFBIG, `ulimit -f`; the SIGXFSZ that would kill the process is
ignored by the command line so that the write raises instead), a read-only or forbidden place."""

from __future__ import annotations

import errno
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from fvfiles.errors import FvtreeError

DISK_FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})  # the disk or a limit has no room left
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
