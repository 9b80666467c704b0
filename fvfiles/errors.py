"""The one root of every error a user acts on: what went wrong, where (file, line, field or node
path), a hint, and the exit code the command line gives it. It sits in the bottom package so that
every package can raise it."""

from __future__ import annotations

import difflib
import errno
import re
from collections.abc import Iterable, Sequence


class FvtreeError(Exception):
    """A located, actionable error: `file:line: field: message (hint)`; exit code 2."""

    exit_code = 2

    def __init__(self, message: str, file: str | None = None, line: int | None = None,
                 field: str | None = None, hint: str | None = None):
        super().__init__(message)
        self.message, self.file, self.line, self.field, self.hint = message, file, line, field, hint

    def __str__(self) -> str:
        where = ":".join(str(p) for p in (self.file, self.line) if p is not None)
        text = f"{where}: " if where else ""
        if self.field:
            text += f"{self.field}: "
        text += self.message
        if self.hint:
            text += f" ({self.hint})"
        return text


# The errnos of a write that found no room: a full disk, a full quota, the file-size limit (ulimit -f).
DISK_FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


class RecordNotWritten(FvtreeError):
    """A record of what stands in the cell (the as-built model) could not be written, e.g. to a
    full disk: the run stops its cell (status FAULT) rather than build on without a record."""


class FvtreeErrors(FvtreeError):
    """Every problem found while checking one input, reported together."""

    def __init__(self, errors: Sequence[FvtreeError]):
        super().__init__("\n".join(map(str, errors)))
        self.errors = errors

    def __str__(self) -> str:
        return self.message


def did_you_mean(word: object, options: Iterable[object]) -> str | None:
    """'did you mean X?' for the closest option, or None."""
    close = difflib.get_close_matches(str(word), [str(o) for o in options], n=1, cutoff=0.6)
    return f"did you mean {close[0]!r}?" if close else None


_FIELD_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]{0,47}")  # what a field name in a tree, design or cell file looks like


def field_name(key: object) -> str:
    """A key as an error message may quote it: `'key'` when it looks like a field name, else only
    its length. A file that is no tree (e.g. `/etc/shadow` given as a tree or an include) parses as
    a mapping whose keys are its lines: an error must not print them."""
    text = str(key)
    if _FIELD_NAME.fullmatch(text):
        return repr(text)
    return f"(a key of {len(text)} characters that is no field name, not shown)"


def did_you_mean_field(key: object, options: Iterable[object]) -> str | None:
    """`did_you_mean` for a key that looks like a field name (see `field_name`); None for any other."""
    return did_you_mean(key, options) if _FIELD_NAME.fullmatch(str(key)) else None
