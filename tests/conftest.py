"""Shared fixtures: a clean py_trees blackboard per test, and paths into the repository.

BLAS and OpenMP run on one thread in the tests and the processes they start (set before numpy is
first imported): `make test` already runs one test worker per core, and OpenBLAS's own threads on
top of them spin against each other (a 300-row kernel-ridge grid search: 0.6 s on one thread, 9.7 s
on two, on a busy two-core machine). The simulated runs give the same results either way."""

from __future__ import annotations

import os

for threads in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):  # before the imports below bring numpy in
    os.environ.setdefault(threads, "1")

from pathlib import Path

import pytest

from assembly.run.perception_stage import clear_blackboard

ROOT = Path(__file__).resolve().parents[1]
TREES = ROOT / "trees"


@pytest.fixture(autouse=True)
def clean_blackboard():
    clear_blackboard()
    yield
    clear_blackboard()


@pytest.fixture
def shipped_designs_allowed(monkeypatch):
    """Trees written outside the repository (a temp dir, a BT.CPP import) may name the shipped
    designs in trees/design/: a design, like an include, is read only under the tree's folder or
    one FVTREE_INCLUDE_PATH allows (`fvtree --allow-include DIR`)."""
    from assembly.language.reader import INCLUDE_PATH

    monkeypatch.setenv(INCLUDE_PATH, str(TREES))


@pytest.fixture
def tree_file(tmp_path):
    """Write a tree (and any extra files) into a temp dir; returns the tree's path."""

    def write(text: str, name: str = "tree.yaml", **others: str) -> Path:
        for rel, content in others.items():
            target = tmp_path / rel.replace("__", "/")
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(content)
        path = tmp_path / name
        path.write_text(text)
        return path

    return write



@pytest.fixture(scope="session")
def record_shortened(tmp_path_factory):
    """Record a demo tree `trees/<name>.yaml` with its repeat count cut from `times[0]` to
    `times[1]` (a shorter recording for tests); returns the loaded Dataset."""
    from assembly.dataset_recorder import record
    from perception.learning.dataset import Dataset

    def recorded(name: str, times: tuple[int, int], cell: str = "sim") -> Dataset:
        tree = tmp_path_factory.mktemp(name) / f"{name}.yaml"
        tree.write_text((TREES / f"{name}.yaml").read_text().replace(f"times: {times[0]}", f"times: {times[1]}"))
        return Dataset.load(record(tree, tree.with_suffix(".npz"), cell=cell))

    return recorded
