"""Where fvtree keeps what it compiles: numba's cache of compiled kernels (`@njit(cache=True)`)
goes to a user cache directory, not next to the sources, so that fvtree runs from an installation
its user cannot write (a system site-packages, a read-only checkout). numba's own fallbacks (the
sources' `__pycache__`, then `~/.cache/numba`) fail together for a user without a writable home
(`cannot cache function ...: no locator available`), and numba then refuses to import the kernels.

`use_user_cache_for_numba()` sets NUMBA_CACHE_DIR, unless the user has set it, to the first of
these that can be written: `$XDG_CACHE_HOME/fvtree/numba` (default `~/.cache/fvtree/numba`; on
macOS `~/Library/Caches/fvtree/numba`; on Windows `%LOCALAPPDATA%\\fvtree\\numba`), then
`<temp dir>/fvtree-<uid>/numba` (private to the user). Every package that compiles kernels calls it
in its `__init__`, before numba reads its configuration (once, when it is first imported)."""

from __future__ import annotations

import os
import stat
import sys
import tempfile
from pathlib import Path

NUMBA_CACHE_DIR = "NUMBA_CACHE_DIR"


def user_cache_dir(app: str = "fvtree") -> Path:
    """The platform's per-user cache directory for `app` (the XDG base directory rule on Linux)."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local") / app
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches" / app
    xdg = os.environ.get("XDG_CACHE_HOME")
    return Path(xdg if xdg and Path(xdg).is_absolute() else Path.home() / ".cache") / app


def _writable_dir(path: Path) -> bool:
    """Create `path` (private to the user) if needed and check a file can be made in it."""
    try:
        path.mkdir(parents=True, exist_ok=True, mode=0o700)
        with tempfile.TemporaryFile(dir=path):
            pass
    except (OSError, RuntimeError):  # RuntimeError: Path.home() without a home
        return False
    return True


def _private(path: Path) -> bool:
    """`path` and its parent are real directories of this user that no one else may write: numba's
    cache holds pickles it loads, so a shared temp directory must not let another user plant them."""
    if not hasattr(os, "getuid"):
        return True
    for part in (path.parent, path):
        try:
            info = os.lstat(part)
        except OSError:
            return False
        if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid() or info.st_mode & 0o022:
            return False
    return True


def _candidates() -> list[tuple[Path, bool]]:
    """(directory, whether it must be checked private) in the order they are tried."""
    uid = os.getuid() if hasattr(os, "getuid") else os.getpid()
    found = []
    try:
        found.append((user_cache_dir() / "numba", False))
    except RuntimeError:  # no home directory to be found
        pass
    return [*found, (Path(tempfile.gettempdir()) / f"fvtree-{uid}" / "numba", True)]


def use_user_cache_for_numba() -> str | None:
    """Point numba's kernel cache at a user cache directory (see the module docstring) unless the
    user chose one; the directory in use, or None when none can be written (numba then falls back
    on its own locators)."""
    if os.environ.get(NUMBA_CACHE_DIR):
        return os.environ[NUMBA_CACHE_DIR]
    for path, shared in _candidates():
        if _writable_dir(path) and (not shared or _private(path)):
            os.environ[NUMBA_CACHE_DIR] = str(path)
            return str(path)
    return None
