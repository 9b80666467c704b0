"""Shared fixtures: a clean py_trees blackboard per test, and paths into the repository."""

from __future__ import annotations

from pathlib import Path

import py_trees
import pytest

ROOT = Path(__file__).resolve().parents[1]
TREES = ROOT / "trees"


@pytest.fixture(autouse=True)
def clean_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


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
