"""The dataflow check of a validated tree: every blackboard key a node reads must be written by
something that ticks before it (or by the perception stage, before the first tick)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from assembly.errors import TreeError
from assembly.language.validator import NodeKind, NodeSpec
from behaviours.skill_kit.registry import SKILLS


def dataflow_errors(root: NodeSpec, kinds: Mapping[str, NodeKind], provided: Iterable[str]) -> list[TreeError]:
    """A problem for every key a node reads that no node ticking before it writes.

    `provided` keys are on the blackboard before the first tick (the cell's perception stage
    publishes them). A node sees what its ancestors publish to their children (`for_each_element`:
    the task keys) and everything earlier siblings may write; the children of a `concurrent` kind
    (parallel) see everything any sibling may write. "May write" is everything a subtree can write
    on any path, so the check never refuses a tree that could run, and a node is not asked for the
    keys it writes itself (skills that carry state from tick to tick).
    """
    written: dict[int, frozenset[str]] = {}

    def writes(spec: NodeSpec) -> frozenset[str]:
        if id(spec) not in written:
            kind = kinds[spec.kind]
            own = set(kind.keys(spec)[1]) if kind.keys else set()
            written[id(spec)] = frozenset(own | kind.publishes).union(*(writes(c) for c in spec.children))
        return written[id(spec)]

    errors: list[TreeError] = []

    def visit(spec: NodeSpec, available: frozenset[str]) -> None:
        kind = kinds[spec.kind]
        if kind.keys:
            reads, own = kind.keys(spec)
            for key in reads:
                if key not in available and key not in own:
                    writers = sorted({k for k, other in kinds.items() if key in other.publishes}
                                     | {f"skill {name}" for name, cls in SKILLS.items() if key in cls.WRITES})
                    errors.append(TreeError(
                        f"{spec.kind} {spec.type or spec.name!r} reads {key}, which nothing ticking before it writes",
                        spec.file, spec.line, spec.path,
                        f"written by {', '.join(writers)}" if writers else "nothing writes it"))
        inner = available | kind.publishes
        if kind.concurrent:
            inner = inner.union(*(writes(c) for c in spec.children))
        for child in spec.children:
            visit(child, inner)
            inner = inner | writes(child)

    visit(root, frozenset(provided))
    return errors
