"""Ticking without generators (`assembly.nodes.composites`, `Skill.tick_once`) does what py_trees' generator
ticks do: on random trees of every kind the YAML language builds, with leaves answering scripted
statuses, each tick gives every node the same status, feedback and current child, and the leaves
the same initialise, update and terminate calls in the same order."""

from __future__ import annotations

import random

import py_trees
import pytest
from py_trees.common import Status

from assembly.nodes import composites, decorators
from assembly.nodes.decorators import CellTimeout, StatusMap
from assembly.run.loop import BehaviourTree
from behaviours.skill_kit.base import Skill

STATUSES = (Status.RUNNING, Status.RUNNING, Status.SUCCESS, Status.FAILURE)


class Scripted:
    """A leaf answering the statuses of its script in turn (the last one for ever), logging its calls."""

    def __init__(self, name: str, script: list[Status], log: list):
        super().__init__(name=name)
        self.script, self.log, self.calls = script, log, 0

    def initialise(self) -> None:
        self.log.append(("initialise", self.name))

    def update(self) -> Status:
        status = self.script[min(self.calls, len(self.script) - 1)]
        self.calls += 1
        self.feedback_message = f"call {self.calls}"
        self.log.append(("update", self.name, status))
        return status

    def terminate(self, new_status: Status) -> None:
        self.log.append(("terminate", self.name, self.status, new_status))
        super().terminate(new_status)


class ScriptedBehaviour(Scripted, py_trees.behaviour.Behaviour):
    """The leaf in the reference tree: py_trees' own tick."""


class ScriptedSkill(Scripted, Skill):
    """The leaf in the tree ticked without generators."""

    NAME = "scripted"


class Clock:
    def __init__(self):
        self.t = 0.0

    def now(self) -> float:
        return self.t


# Kind -> (reference class, class ticked without generators) of the composites and decorators.
COMPOSITES = {"sequence": (py_trees.composites.Sequence, composites.Sequence),
              "selector": (py_trees.composites.Selector, composites.Selector)}
DECORATORS = {"pass_through": (py_trees.decorators.PassThrough, decorators.PassThrough),
              "retry": (py_trees.decorators.Retry, decorators.Retry),
              "repeat": (py_trees.decorators.Repeat, decorators.Repeat),
              "inverter": (py_trees.decorators.Inverter, decorators.Inverter),
              "status_map": (StatusMap, StatusMap), "timeout": (CellTimeout, CellTimeout),
              "guard": (py_trees.decorators.EternalGuard, py_trees.decorators.EternalGuard)}


def random_spec(rng: random.Random, depth: int = 0) -> tuple:
    """A random tree: (kind, name, args, children) tuples, leaves with their status scripts."""
    name = f"n{rng.randrange(10**9)}"
    if depth >= 4 or depth and rng.random() < 0.3:  # the root is never a leaf
        return ("leaf", name, [rng.choice(STATUSES) for _ in range(rng.randint(1, 8))], [])
    kind = rng.choice([*COMPOSITES, *COMPOSITES, *DECORATORS, "parallel"])
    if kind in COMPOSITES or kind == "parallel":
        kids = [random_spec(rng, depth + 1) for _ in range(rng.randint(1, 4))]
        return (kind, name, rng.random() < 0.5, kids)
    args = {"retry": rng.randint(1, 3), "repeat": rng.choice([-1, 1, 2, 3]), "timeout": rng.choice([0.3, 1.0]),
            "status_map": {Status.FAILURE: Status.SUCCESS}, "guard": [rng.random() < 0.8 for _ in range(20)]}
    return (kind, name, args.get(kind), [random_spec(rng, depth + 1)])


def build(spec: tuple, direct: bool, log: list, clock: Clock) -> py_trees.behaviour.Behaviour:
    """The tree of `spec` of py_trees' classes (`direct` False) or of those ticked without generators."""
    kind, name, args, children = spec
    kids = [build(child, direct, log, clock) for child in children]
    if kind == "leaf":
        return (ScriptedSkill if direct else ScriptedBehaviour)(name, args, log)
    if kind in COMPOSITES:
        return COMPOSITES[kind][direct](name=name, memory=args, children=kids)
    if kind == "parallel":
        return py_trees.composites.Parallel(name, py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=args), kids)
    cls = DECORATORS[kind][direct]
    if kind == "retry":
        return cls(name=name, child=kids[0], num_failures=args)
    if kind == "repeat":
        return cls(name=name, child=kids[0], num_success=args)
    if kind == "status_map":
        return cls(name, kids[0], args)
    if kind == "timeout":
        node = cls(name, kids[0], args)
        node.clock = clock
        return node
    if kind == "guard":
        answers = iter(args * 100)
        return cls(name=name, child=kids[0], condition=lambda: next(answers))
    return cls(name=name, child=kids[0])


def state(root: py_trees.behaviour.Behaviour) -> list[tuple]:
    """Every node's name, status, feedback and current child, and the tip."""
    tip = root.tip()
    return [(n.name, n.status, n.feedback_message, getattr(getattr(n, "current_child", None), "name", None))
            for n in root.iterate()] + [("tip", tip.name if tip else None)]


@pytest.mark.parametrize("seed", range(300))
def test_ticking_without_generators_matches_py_trees(seed):
    rng = random.Random(seed)
    spec = random_spec(rng)
    reference_log, direct_log = [], []
    reference_clock, direct_clock = Clock(), Clock()
    reference = build(spec, False, reference_log, reference_clock)
    direct = build(spec, True, direct_log, direct_clock)
    for tick in range(40):
        for clock in (reference_clock, direct_clock):
            clock.t = 0.1 * tick
        for _ in reference.tick():
            pass
        direct.tick_once()
        assert direct_log == reference_log, f"tick {tick}"
        assert state(direct) == state(reference), f"tick {tick}"
        if rng.random() < 0.05:  # a halt from outside, as the stop policy's
            reference.stop(Status.INVALID)
            direct.stop(Status.INVALID)
            assert direct_log == reference_log and state(direct) == state(reference)


def test_generator_ticks_are_py_trees_own():
    assert composites.Sequence.tick is py_trees.composites.Sequence.tick
    assert composites.Selector.tick is py_trees.composites.Selector.tick
    assert decorators.Retry.tick is py_trees.decorators.Decorator.tick


def test_a_node_changing_how_it_ticks_changes_both_ways():
    def tick(self):
        yield self

    with pytest.raises(TypeError, match="tick_once"):
        type("OwnTick", (decorators.DirectDecorator, py_trees.decorators.Decorator), {"tick": tick})
    with pytest.raises(TypeError, match="tick_once"):
        type("OwnTick", (Skill,), {"tick": tick})


def test_the_runner_ticks_without_generators_unless_the_tree_has_visitors():
    """With a visitor, py_trees' generator ticks show it every ticked node; either way, the same states."""
    spec = random_spec(random.Random(7))
    trees = {}
    for visited in (False, True):
        log: list = []
        tree = BehaviourTree(build(spec, True, log, Clock()))
        if visited:
            seen = []
            visitor = py_trees.visitors.VisitorBase(full=False)
            visitor.run = seen.append
            tree.add_visitor(visitor)
        for _ in range(20):
            tree.tick()
        trees[visited] = (log, state(tree.root))
    assert trees[True] == trees[False]
    assert seen and tree.root in seen
