"""Errors in tree, subtree and design files: located by file, line and node path."""

from __future__ import annotations

from fvfiles.errors import FvtreeError, FvtreeErrors


class TreeError(FvtreeError):
    """A problem in a tree, subtree include or design file; `path` is the node path."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None,
                 path: str | None = None, hint: str | None = None):
        super().__init__(message, file, line, path, hint)

    @property
    def path(self) -> str | None:
        return self.field


class TreeErrors(FvtreeErrors):
    """All the problems found while validating one tree file."""
