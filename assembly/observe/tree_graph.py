"""The tree as a graph for the viewer: node ids (paths), labels, edges, a top-down layout and the
colour of each status, from the validated document (no py_trees objects needed, so a replay of an
old run directory can draw it too)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from assembly.language.validator import NodeSpec

STATUS_COLOURS = {  # RGBA; the colours of py_trees' own dot renderings, status by status
    "INVALID": (150, 150, 150, 255),
    "RUNNING": (70, 130, 230, 255),
    "SUCCESS": (60, 180, 75, 255),
    "FAILURE": (220, 50, 47, 255),
}
STATUSES = tuple(STATUS_COLOURS)
X_STEP, Y_STEP = 120.0, 80.0  # viewer units between neighbouring leaves and between levels


@dataclass(frozen=True)
class TreeGraph:
    """Nodes in depth-first order (`paths[i]` is node i), their labels, top-down positions
    (root on top, leaves spread left to right, parents centred over their children) and the
    parent -> child edges."""

    paths: list[str]
    labels: list[str]  # node names (the paths and kinds are in the node ids and `fvtree show`)
    positions: np.ndarray  # (N, 2)
    edges: list[tuple[str, str]]

    def colours(self, statuses: list[str]) -> np.ndarray:
        """(N, 4) uint8 colours of the nodes' statuses, given in `paths` order."""
        return np.array([STATUS_COLOURS.get(s, STATUS_COLOURS["INVALID"]) for s in statuses], np.uint8)


def tree_graph(root: NodeSpec) -> TreeGraph:
    """Lay a tree out top-down: each leaf takes the next column, each parent sits centred over
    its children, one row per depth."""
    paths: list[str] = []
    labels: list[str] = []
    where: dict[str, tuple[float, float]] = {}
    edges: list[tuple[str, str]] = []
    next_column = [0.0]

    def place(spec: NodeSpec, depth: int) -> float:
        paths.append(spec.path)
        labels.append(spec.name)
        if spec.children:
            columns = []
            for child in spec.children:
                edges.append((spec.path, child.path))
                columns.append(place(child, depth + 1))
            x = (min(columns) + max(columns)) / 2.0
        else:
            x = next_column[0]
            next_column[0] += 1.0
        where[spec.path] = (x * X_STEP, depth * Y_STEP)
        return x

    place(root, 0)
    return TreeGraph(paths, labels, np.array([where[p] for p in paths], float), edges)
