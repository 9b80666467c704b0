"""The exit codes of `fvtree` and the printing of a located error, shared by every command."""

from __future__ import annotations

import sys

from fvfiles.errors import FvtreeError, FvtreeErrors

EXIT_FAILURE = 1  # the tree ran and failed, or a check failed
EXIT_USAGE = FvtreeError.exit_code  # bad input: a tree, design, cell or data file, or an argument


def report(exc: FvtreeError) -> int:
    """Print a located error (each of them, for a list) on stderr; returns its exit code."""
    for err in exc.errors if isinstance(exc, FvtreeErrors) else [exc]:
        print(err, file=sys.stderr)
    return exc.exit_code
