"""Errors a user acts on: each names the file, the line and the node path, with a hint."""

from __future__ import annotations


class TreeError(Exception):
    """A problem in a tree, subtree include or design file, located for the user."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None,
                 path: str | None = None, hint: str | None = None):
        super().__init__(message)
        self.message, self.file, self.line, self.path, self.hint = message, file, line, path, hint

    def __str__(self) -> str:
        where = ":".join(str(p) for p in (self.file, self.line) if p is not None)
        text = f"{where}: " if where else ""
        if self.path:
            text += f"{self.path}: "
        text += self.message
        if self.hint:
            text += f" ({self.hint})"
        return text


class TreeErrors(Exception):
    """All the problems found while validating one file."""

    def __init__(self, errors: list[TreeError]):
        super().__init__("\n".join(map(str, errors)))
        self.errors = errors


def did_you_mean(word: str, options) -> str | None:
    """'did you mean X?' for the closest option, or None."""
    import difflib

    close = difflib.get_close_matches(str(word), [str(o) for o in options], n=1, cutoff=0.6)
    return f"did you mean {close[0]!r}?" if close else None
