"""Where the tree is: the path of its tip (the deepest running node) after each tick."""

from __future__ import annotations

import py_trees

from assembly.language.build import BuiltTree


class Tip:
    """Post-tick handler keeping the path of the tree's tip; it holds the last known path while
    the tree is stopped (every node INVALID), so a halted run still says where it was."""

    def __init__(self, tree: BuiltTree):
        self.tree = tree
        self.path = ""

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        tip = tree.root.tip()
        if tip is not None:
            self.path = self.tree.path_of(tip)
