"""Build the py_trees tree of a validated document, with a stable path per node."""

from __future__ import annotations

from dataclasses import dataclass

import py_trees

from assembly.language.doubles import DOUBLE_KINDS
from assembly.language.kinds import NODE_KINDS
from assembly.language.reader import TreeDocument
from assembly.language.validator import NodeSpec


@dataclass
class BuiltTree:
    """The py_trees tree of a document, with every node addressable by its path."""

    document: TreeDocument
    root: py_trees.behaviour.Behaviour
    nodes: dict[str, py_trees.behaviour.Behaviour]  # path -> node

    def path_of(self, node: py_trees.behaviour.Behaviour) -> str:
        return self._paths[node]

    def __post_init__(self):
        # Keyed by the nodes themselves (hashed by identity, in C): the tip's path is looked up every
        # tick, and a node's uuid hashes in Python at three times the cost.
        self._paths = {node: path for path, node in self.nodes.items()}


def build(doc: TreeDocument) -> BuiltTree:
    """The py_trees tree of a validated document: each node built by its kind (or, for a test
    double `assembly.language.substitution` put in place, by its double kind), children first."""
    nodes: dict[str, py_trees.behaviour.Behaviour] = {}

    def make(spec: NodeSpec) -> py_trees.behaviour.Behaviour:
        kind = NODE_KINDS[spec.kind] if spec.kind in NODE_KINDS else DOUBLE_KINDS[spec.kind]
        node = kind.build(spec, [make(c) for c in spec.children])
        nodes[spec.path] = node
        return node

    root = make(doc.root)
    return BuiltTree(doc, root, nodes)
