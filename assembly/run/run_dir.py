"""Run directories: one per run, named by start time and tree, with a `run.json` saying which tree
and design (by SHA-256 of their files) the run builds, so that `--resume` continues only the run
of the same tree, unchanged."""

from __future__ import annotations

import hashlib
import json
import math
import re
import time
from pathlib import Path

from assembly.errors import TreeError
from assembly.language.reader import TreeDocument
from fvfiles.json_files import atomic_write_json

RUN_FILE = "run.json"
ASBUILT_FILE = "asbuilt.json"
EVENTS_FILE = "events.jsonl"


def safe_name(tree_name: str) -> str:
    """A tree name usable as one path component: letters, digits, `_` and `-` only."""
    name = re.sub(r"[^A-Za-z0-9_-]+", "_", tree_name).strip("_")
    return name[:80] or "tree"


def new_run_dir(base: Path, tree_name: str) -> Path:
    """Create `base/<YYYYmmdd-HHMMSS>-<tree>` (with `-1`, `-2`, ... if taken) and return it; the
    tree name is sanitised, so the directory is always directly inside `base`."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for i in range(1000):
        path = base / (f"{stamp}-{safe_name(tree_name)}" + (f"-{i}" if i else ""))
        try:
            path.mkdir(parents=True)
            return path
        except FileExistsError:
            continue
    raise RuntimeError(f"cannot create a run directory under {base}")


def _sha256_of(paths: list[Path]) -> str:
    digest = hashlib.sha256()
    for path in paths:
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def fingerprint(doc: TreeDocument) -> dict:
    """What a run builds: the tree's name and the SHA-256 of its files (the tree file and each
    file its nodes come from) and of its design file."""
    files = {Path(doc.path).resolve()}
    stack = [doc.root]
    while stack:
        spec = stack.pop()
        if spec.file and Path(spec.file).is_file():
            files.add(Path(spec.file).resolve())
        stack.extend(spec.children)
    design = doc.design.path if doc.design is not None else None
    return {"tree": doc.name, "tree_sha256": _sha256_of(sorted(files)),
            "design_sha256": _sha256_of([design]) if design is not None else None}


def write_run_file(run_dir: Path, doc: TreeDocument, **details) -> None:
    """Record at the start what the run builds (see `fingerprint`), when it started (`started`,
    Unix time: what `--resume` orders runs by) and how (`details`)."""
    atomic_write_json(run_dir / RUN_FILE, {**fingerprint(doc), "tree_file": str(doc.path), "started": time.time(),
                                           **details})


def _run_file(run_dir: Path) -> dict | None:
    try:
        data = json.loads((run_dir / RUN_FILE).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and (run_dir / ASBUILT_FILE).is_file() else None


def _start_order(run: tuple[Path, dict]) -> tuple[float, int, str]:
    """Sort key of a run by its start: the `started` time its run.json records (a run from before
    that field: the time run.json was written), then the `-N` suffix `new_run_dir` gave runs
    started in the same second (numerically: `-10` after `-9`), then the name."""
    path, data = run
    started = data.get("started")
    if isinstance(started, bool) or not isinstance(started, (int, float)) or not math.isfinite(started):
        try:
            started = (path / RUN_FILE).stat().st_mtime
        except OSError:
            started = 0.0
    suffix = re.search(r"-(\d{1,3})$", path.name)
    return float(started), int(suffix.group(1)) if suffix else 0, path.name


def find_run(runs_dir: Path, resume: str, doc: TreeDocument) -> Path:
    """The run directory to resume: `resume` itself, or for "latest" the run of exactly this tree
    under `runs_dir` started last (see `_start_order`); checked to be a run of this tree with its files unchanged."""
    if resume != "latest":
        run_dir = Path(resume)
    else:
        runs = [(p, data) for p in runs_dir.glob("*") if p.is_dir()
                for data in [_run_file(p)] if data is not None and data.get("tree") == doc.name]
        if not runs:
            raise TreeError(f"no earlier run of {doc.name!r} to resume", str(runs_dir))
        run_dir = max(runs, key=_start_order)[0]
    recorded = _run_file(run_dir)
    if recorded is None:
        raise TreeError(f"not a run directory ({RUN_FILE} and {ASBUILT_FILE} are needed)", str(run_dir))
    now = fingerprint(doc)
    if recorded.get("tree") != doc.name:
        raise TreeError(f"this is a run of {recorded.get('tree')!r}, not of {doc.name!r}", str(run_dir / RUN_FILE))
    for key, what in (("tree_sha256", "the tree (or a file it includes)"), ("design_sha256", "the design")):
        if recorded.get(key) != now[key]:
            raise TreeError(f"{what} changed since this run started, so it cannot be resumed",
                            str(run_dir / RUN_FILE), hint="start a new run, or restore the files the run began with")
    return run_dir
