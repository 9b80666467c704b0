"""`fvtree show`: the tree as text, each node with its kind, params and (from a run's
transition log) its last status."""

from __future__ import annotations

import json
from pathlib import Path

from assembly.language.kinds import NODE_KINDS
from assembly.language.reader import TreeDocument
from assembly.language.validator import NodeSpec
from fvfiles.errors import FvtreeError

MARKS = {"SUCCESS": "✔", "FAILURE": "✘", "RUNNING": "*", "INVALID": "-"}


def final_statuses(run_dir: Path) -> dict[str, str]:
    """Last status of every node path in a run's transitions.jsonl."""
    statuses: dict[str, str] = {}
    log = run_dir / "transitions.jsonl"
    if not log.is_file():
        raise FvtreeError("no transition log", str(log), hint=f"is {run_dir} a run directory?")
    with open(log) as f:
        for number, line in enumerate(f, 1):
            if line.strip():
                try:
                    record = json.loads(line)
                    statuses[record["node"]] = record["to"]
                except (ValueError, KeyError, TypeError):
                    raise FvtreeError("not a transition record {node, to, ...}", str(log), number) from None
    return statuses


def label(spec: NodeSpec) -> str:
    """`name [kind details]`, as its kind labels it."""
    return f"{spec.name} {NODE_KINDS[spec.kind].label(spec)}"


def render(doc: TreeDocument, run_dir: Path | None = None) -> str:
    """The tree as indented text; with `run_dir`, each node marked with its final status."""
    statuses = final_statuses(run_dir) if run_dir else {}
    lines = [f"{doc.name}  ({doc.path}, {doc.tick_hz:g} Hz, scene {doc.scene})"]

    def walk(spec: NodeSpec, prefix: str, last: bool, top: bool):
        mark = MARKS.get(statuses.get(spec.path, "INVALID"), "?") if run_dir else ""
        branch = "" if top else ("└── " if last else "├── ")
        lines.append(f"{prefix}{branch}{mark + ' ' if mark else ''}{label(spec)}")
        child_prefix = prefix + ("" if top else ("    " if last else "│   "))
        for i, child in enumerate(spec.children):
            walk(child, child_prefix, i == len(spec.children) - 1, False)

    walk(doc.root, "", True, True)
    if run_dir:
        lines.append("legend: ✔ success  ✘ failure  * running  - not ticked")
    return "\n".join(lines)
