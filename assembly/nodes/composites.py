"""py_trees' sequence and selector, ticked without generators.

py_trees ticks a tree through nested generators: each node yields itself, and every node below it
is yielded up through each level above, so that visitors can look at the nodes as they are ticked.
A run has no visitors, and walking those generators down from the root every tick cost the
assembly about as much as its skills' own work. The classes here add `tick_once`, which py_trees
documents as ticking "without iterating step-by-step over the children (i.e. without generators)":
the steps of py_trees' own `tick`, in the same order, with each child ticked by its `tick_once`.
Statuses, feedback, `initialise`, `terminate` and `stop` calls are the same either way
(tests/test_composites.py compares the two on random trees); py_trees' debug log lines are left
out. `tick` stays py_trees' own, for a tree with visitors. The decorators do the same
(`assembly.nodes.decorators.DirectDecorator`).

A node of another kind (a plugin's, py_trees' parallel) keeps py_trees' `tick_once`, which runs
its generator; under it, children tick through their generators as before.
"""

from __future__ import annotations

import py_trees
from py_trees.common import Status

RUNNING, SUCCESS, FAILURE, INVALID = Status.RUNNING, Status.SUCCESS, Status.FAILURE, Status.INVALID


class Sequence(py_trees.composites.Sequence):
    """py_trees' Sequence, with `tick_once` ticking its children without generators."""

    def tick_once(self) -> None:
        """py_trees' `Sequence.tick`: start over unless running (from the running child with
        memory), tick the children in order until one does not succeed and take its status."""
        children = self.children
        index = 0
        if self.status is not RUNNING:
            self.current_child = children[0] if children else None
            _stop_all(children)
            self.initialise()
        elif self.memory and self.current_child is not None:
            index = children.index(self.current_child)
        else:
            self.current_child = children[0] if children else None
        if not children:
            self.current_child = None
            self.stop(SUCCESS)
            return
        for child in children[index:]:
            child.tick_once()
            status = child.status
            if status is not SUCCESS:
                if not self.memory:
                    _stop_all(children[index + 1:])
                if status is RUNNING:
                    self.status = status
                else:
                    self.stop(status)
                return
            if index + 1 < len(children):
                index += 1
                self.current_child = children[index]
        self.stop(SUCCESS)


class Selector(py_trees.composites.Selector):
    """py_trees' Selector, with `tick_once` ticking its children without generators."""

    def tick_once(self) -> None:
        """py_trees' `Selector.tick`: tick the children in priority order (from the running one with
        memory) until one runs or succeeds, halting the lower priorities when the choice changed."""
        children = self.children
        if self.status is not RUNNING:
            self.current_child = children[0] if children else None
            self.initialise()
        if not children:
            self.current_child = None
            self.stop(FAILURE)
            return
        index = 0
        if self.memory:
            assert self.current_child is not None  # the first child, or the one left running
            index = children.index(self.current_child)
            _stop_all(children[:index])
        previous = self.current_child
        for child in children[index:]:
            child.tick_once()
            status = child.status
            if status is RUNNING or status is SUCCESS:
                self.current_child = child
                if previous is not child:
                    _stop_all(children[children.index(child) + 1:])
                if status is SUCCESS:
                    self.stop(status)
                else:
                    self.status = status
                return
        self.stop(FAILURE)
        self.current_child = children[-1]


def _stop_all(nodes: list[py_trees.behaviour.Behaviour]) -> None:
    """Halt (stop with INVALID) each of `nodes` that is not INVALID already, in order."""
    for node in nodes:
        if node.status is not INVALID:
            node.stop(INVALID)
