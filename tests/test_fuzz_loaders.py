"""Fuzzing the tree, design and cell loaders: every input either loads or gives a located error
(an FvtreeError naming the file), never another exception and never a hang.

Inputs are the shipped files with random mutations (tokens YAML and JSON treat specially:
aliases, anchors, brackets, NaN, control characters, invalid UTF-8, complex keys, typos of known
fields...). The hypothesis tests run 3000 inputs in all. `python tests/test_fuzz_loaders.py
[--root DIR] [--count N]` runs a seeded corpus through the loaders of the checkout at DIR and
prints tried / located errors / other exceptions / hangs per loader (DIR may hold an older
layout of the code: the same corpus then measures it).
"""

from __future__ import annotations

import random
import resource
import shutil
import signal
import sys
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TIMEOUT_S = 10  # s of CPU time per input: far beyond any honest load
TOKENS = [b".nan", b".inf", b"-.inf", b"NaN", b"Infinity", b"*a", b"&a ", b"*b", b"[", b"]", b"{", b"}", b": ",
          b"- ", b"\n", b"  ", b"\t", b"\x00", b"\x07", b"\x1b", b"\xff", b"\xc3", b"? ", b"? [a, b]\n: 1\n",
          b"!!python/object/apply:os.system ['true'] ", b"!!set ", b"!!binary ", b"~", b"null", b"-1", b"0", b"1e400",
          b"1.0e400", b"'", b'"', b"#", b"<<: *a\n", b"&a [*a]", b"E9", b"sim_lod", b"statu", b"placing", b"[[[[[[[[",
          b"{skill: {}}", b"skill: [a]", b"subtree: ", b"version: 2", b"elements: [E1, E9]", b"memory: 1",
          b"kind: real", b"kind: [sim]", b"home: [9, 9, 9, 0, 0, 0]", b"workspace_min: [1, 1, 1]",
          b"max_force: .nan", b"link_timeout: -1", b"host: 127.0.0.1.example", b"time_scale: 1000",
          b"scene: nowhere", b"model: ../../etc/passwd", b"\"id\": [1]", b"\"nodes\": 1", b",", b"\xef\xbb\xbf"]

TREE_SEEDS = sorted(p.name for p in (ROOT / "trees").glob("*.yaml"))
CELL_SEEDS = sorted(p.name for p in (ROOT / "drivers" / "cells").glob("*.yaml"))
DESIGN_SEEDS = ["two_bays.json"]


def mutate(data: bytes, ops: list[tuple[int, float, float, bytes]]) -> bytes:
    """`data` changed by each (op, where, span, token): insert, replace, delete, duplicate or
    swap lines, truncate, flip a byte, repeat a token; where and span are fractions of the length."""
    for op, where, span, token in ops:
        at, width = int(where * len(data)), 1 + int(span * 40)
        if op == 0:
            data = data[:at] + token + data[at:]
        elif op == 1:
            data = data[:at] + token + data[at + width:]
        elif op == 2:
            data = data[:at] + data[at + width:]
        elif op in (3, 4):
            lines = data.split(b"\n")
            i, j = int(where * len(lines)) % len(lines), int(span * len(lines)) % len(lines)
            if op == 3:
                lines.insert(i, lines[j])
            else:
                lines[i], lines[j] = lines[j], lines[i]
            data = b"\n".join(lines)
        elif op == 5:
            data = data[:at]
        elif op == 6 and data:
            data = data[:at % len(data)] + bytes([data[at % len(data)] ^ (1 << int(span * 8) % 8)]) + data[at % len(data) + 1:]
        else:
            data = data[:at] + token * (1 + int(span * 30)) + data[at:]
    return data


class Hang(Exception):
    """An input took longer than TIMEOUT_S of CPU time."""


@contextmanager
def time_limit(seconds: float):
    """Raise Hang in the main thread after `seconds` of the process's CPU time (SIGPROF): what a
    runaway parse burns, whatever else a loaded machine runs meanwhile."""
    def fire(signum, frame):
        raise Hang()
    previous = signal.signal(signal.SIGPROF, fire)
    signal.setitimer(signal.ITIMER_PROF, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGPROF, previous)


class Workspace:
    """A directory with a copy of the shipped trees (their includes, designs and models) and
    cells, where a mutated input is written before each load."""

    def __init__(self, root: Path, work: Path):
        self.root, self.work = root, work
        shutil.copytree(root / "trees", work / "trees", dirs_exist_ok=True)
        shutil.copytree(root / "drivers" / "cells", work / "cells", dirs_exist_ok=True)

    def seed(self, loader: str, name: str) -> bytes:
        folder = {"tree": self.root / "trees", "design": self.root / "trees" / "design",
                  "cell": self.root / "drivers" / "cells"}[loader]
        return (folder / name).read_bytes()

    def write(self, loader: str, data: bytes) -> Path:
        path = {"tree": self.work / "trees" / "fuzz.yaml", "design": self.work / "trees" / "design" / "fuzz.json",
                "cell": self.work / "cells" / "fuzz.yaml"}[loader]
        path.write_bytes(data)
        return path


def loaders() -> dict[str, Callable[[Path], object]]:
    """The loader of each kind of input, in the layout of the code on sys.path."""
    from assembly.design.model import DesignModel
    from assembly.language.reader import load_tree

    try:
        from drivers.cell_builders import validate as check_cell
    except ImportError:  # an older layout: the same checks, by hand
        check_cell = _old_cell_check
    return {"tree": load_tree, "design": DesignModel.load, "cell": check_cell}


def _old_cell_check(path: Path) -> object:
    """The same checks on the layout of commit 279f73c (before `validate`): read the file, parse
    a real cell, build and close a simulated one."""
    from drivers.cell import read_cell_file

    data = read_cell_file(path)
    if data["kind"] == "real":
        from drivers.real_cell import parse
        return parse(path, data)
    from drivers.cell import load_cell
    return load_cell(str(path), 30.0, "assembly", {}).close()


def _is_located(exc: Exception) -> bool:
    """An error of the project's own (any layout) that names the file it is about."""
    errors = getattr(exc, "errors", None) or [exc]
    own = type(exc).__module__.split(".")[0] in ("assembly", "behaviours", "drivers", "perception")
    return own and all(getattr(e, "file", None) or getattr(e, "path", None) for e in errors)


def outcome(load: Callable[[Path], object], path: Path) -> str:
    """'loaded', 'located' (the project's error naming the file), 'other: <type>' or 'hang'."""
    try:
        with time_limit(TIMEOUT_S):
            load(path)
    except Hang:
        return "hang"
    except Exception as exc:  # noqa: BLE001 - what the property forbids, counted
        return "located" if _is_located(exc) else f"other: {type(exc).__name__}"
    return "loaded"


# ---- the property, by hypothesis -------------------------------------------------------------------
try:
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st
except ImportError:  # the counting script runs without it
    given = None

if given is not None:
    import pytest

    OPS = st.lists(st.tuples(st.integers(0, 7), st.floats(0, 1), st.floats(0, 1), st.sampled_from(TOKENS)),
                   min_size=1, max_size=6)
    def fuzz(examples: int) -> settings:
        # No wall-clock deadline: time_limit bounds each input's CPU time.
        return settings(max_examples=examples, deadline=None, derandomize=True, database=None,
                        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

    @pytest.fixture(scope="module")
    def workspace(tmp_path_factory) -> Workspace:
        return Workspace(ROOT, tmp_path_factory.mktemp("fuzz"))

    def check(workspace: Workspace, loader: str, seed: str, ops) -> None:
        """The input loads, or raises an FvtreeError naming the file, within TIMEOUT_S."""
        from fvfiles.errors import FvtreeError, FvtreeErrors

        data = mutate(workspace.seed(loader, seed), ops)
        try:
            with time_limit(TIMEOUT_S):
                loaders()[loader](workspace.write(loader, data))
        except FvtreeError as exc:
            errors = exc.errors if isinstance(exc, FvtreeErrors) else [exc]
            assert all(e.file for e in errors), f"{loader} input {data[:400]!r}: unlocated {exc}"

    @fuzz(1300)
    @given(seed=st.sampled_from(TREE_SEEDS), ops=OPS)
    def test_every_mutated_tree_loads_or_gives_a_located_error(workspace, seed, ops):
        check(workspace, "tree", seed, ops)

    @fuzz(1200)
    @given(seed=st.sampled_from(DESIGN_SEEDS), ops=OPS)
    def test_every_mutated_design_loads_or_gives_a_located_error(workspace, seed, ops):
        check(workspace, "design", seed, ops)

    @fuzz(500)
    @given(seed=st.sampled_from(CELL_SEEDS), ops=OPS)
    def test_every_mutated_cell_file_loads_or_gives_a_located_error(workspace, seed, ops):
        check(workspace, "cell", seed, ops)


# ---- the counts, for the record ------------------------------------------------------------------------
def corpus(loader: str, seeds: list[str], count: int, rng: random.Random) -> list[tuple[str, list]]:
    return [(rng.choice(seeds), [(rng.randrange(8), rng.random(), rng.random(), rng.choice(TOKENS))
                                 for _ in range(rng.randint(1, 6))]) for _ in range(count)]


def count(root: Path, per_loader: dict[str, int], work: Path) -> dict[str, dict[str, int]]:
    """tried / loaded / located / other / hang per loader, for the code at `root`."""
    sys.path.insert(0, str(root))
    if root != ROOT:  # another checkout: this one's editable install must not fill in its modules
        sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in repr(f).lower()]
        sys.path[:] = [p for p in sys.path if "__editable__" not in p]
        sys.path_importer_cache.clear()
    space, table = Workspace(root, work), {}
    rng = random.Random(0)
    seeds = {"tree": sorted(p.name for p in (root / "trees").glob("*.yaml")), "design": DESIGN_SEEDS,
             "cell": sorted(p.name for p in (root / "drivers" / "cells").glob("*.yaml"))}
    for loader, n in per_loader.items():
        load, row = loaders()[loader], {"tried": 0, "loaded": 0, "located": 0, "other": 0, "hang": 0}
        kinds: dict[str, int] = {}
        for seed, ops in corpus(loader, seeds[loader], n, rng):
            result = outcome(load, space.write(loader, mutate(space.seed(loader, seed), ops)))
            row["tried"] += 1
            row[result.split(":")[0]] += 1
            if result.startswith("other"):
                kinds[result[7:]] = kinds.get(result[7:], 0) + 1
        table[loader] = {**row, "kinds": kinds}
    return table


if __name__ == "__main__":
    import argparse
    import tempfile

    args = argparse.ArgumentParser(description=__doc__)
    args.add_argument("--root", type=Path, default=ROOT)
    args.add_argument("--count", type=int, default=1000, help="inputs per loader")
    options = args.parse_args()
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))  # an expanding bomb fails, not the machine
    with tempfile.TemporaryDirectory() as work:
        for name, row in count(options.root.resolve(), dict.fromkeys(("tree", "design", "cell"), options.count),
                               Path(work)).items():
            print(f"{name:7s} tried {row['tried']:5d}  loaded {row['loaded']:5d}  located errors {row['located']:5d}  "
                  f"other exceptions {row['other']:3d}  hangs {row['hang']:3d}  "
                  f"{row['kinds'] or ''}")
