"""What a round trip must keep: every node's path, kind, type and checked arguments."""

from __future__ import annotations

from typing import Any

from assembly.language.reader import TreeDocument
from assembly.language.validator import NodeSpec


def outline(doc: TreeDocument) -> list[tuple[str, str, str, Any]]:
    """(path, kind, type, args) of every node of the expanded tree, depth first."""
    out = []

    def visit(spec: NodeSpec) -> None:
        out.append((spec.path, spec.kind, spec.type, spec.args))
        for child in spec.children:
            visit(child)

    visit(doc.root)
    return out


def differences(a: TreeDocument, b: TreeDocument) -> list[str]:
    """One line per node that differs between two trees (empty: equivalent), plus the cell settings."""
    lines = [f"{field}: {getattr(a, field)!r} != {getattr(b, field)!r}" for field in ("name", "tick_hz", "scene")
             if getattr(a, field) != getattr(b, field)]
    left, right = {n[0]: n[1:] for n in outline(a)}, {n[0]: n[1:] for n in outline(b)}
    for path in sorted(left.keys() | right.keys()):
        if left.get(path) != right.get(path):
            lines.append(f"{path}: {left.get(path)!r} != {right.get(path)!r}")
    if [n[0] for n in outline(a)] != [n[0] for n in outline(b)]:
        lines.append("the children are in another order")
    return lines
