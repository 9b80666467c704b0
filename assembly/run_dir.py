"""Run directories: one per run, named by start time and tree."""

from __future__ import annotations

import time
from pathlib import Path


def new_run_dir(base: Path, tree_name: str) -> Path:
    """Create `base/<YYYYmmdd-HHMMSS>-<tree>` (with `-1`, `-2`, ... if taken) and return it."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for i in range(1000):
        path = base / (f"{stamp}-{tree_name}" + (f"-{i}" if i else ""))
        try:
            path.mkdir(parents=True)
            return path
        except FileExistsError:
            continue
    raise RuntimeError(f"cannot create a run directory under {base}")
