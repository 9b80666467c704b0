"""`fvtree show`: the tree as text, each node with its kind, params and (from a run's
transition log) its last status, and under a `for_each_element` its last status for each element."""

from __future__ import annotations

import json
import re
from pathlib import Path

from assembly.language.kinds import NODE_KINDS
from assembly.language.reader import TreeDocument
from assembly.language.validator import NodeSpec
from fvfiles.errors import FvtreeError

MARKS = {"SUCCESS": "✔", "FAILURE": "✘", "RUNNING": "*", "HALTED": "■", "INVALID": "-"}
HALTED = "HALTED"  # a node stopped while it ran (RUNNING -> INVALID): by a halt, or by its parent


def final_statuses(run_dir: Path) -> dict[str, dict[str | None, str]]:
    """Last status of every node path in a run's transitions.jsonl, per design element it was
    ticked for (the records' `element`; None outside a `for_each_element`, or in a log written
    before records named it). A node stopped while it ran ends `HALTED`, not INVALID: `show --run`
    tells it from a node never ticked (or reset after it ended)."""
    statuses: dict[str, dict[str | None, str]] = {}
    log = run_dir / "transitions.jsonl"
    if not log.is_file():
        raise FvtreeError("no transition log", str(log), hint=f"is {run_dir} a run directory?")
    with open(log) as f:
        for number, line in enumerate(f, 1):
            if line.strip():
                try:
                    record = json.loads(line)
                    element = record.get("element")
                    by_element = statuses.setdefault(record["node"], {})
                    key = element if isinstance(element, str) else None
                    by_element.pop(key, None)  # the latest record last: the node's own last status
                    halted = record["to"] == "INVALID" and record.get("from") == "RUNNING"
                    by_element[key] = HALTED if halted else record["to"]
                except (ValueError, KeyError, TypeError, AttributeError):
                    raise FvtreeError("not a transition record {node, to, ...}", str(log), number) from None
    return statuses


def _marks(by_element: dict[str | None, str], per_element: bool) -> str:
    """A node's last status mark and, `per_element` (under a `for_each_element`), its last status
    for each element it was ticked for (`✔ [E1 ✔ E2 ✘]`)."""
    if not by_element:
        return MARKS["INVALID"]
    mark = MARKS.get(list(by_element.values())[-1], "?")
    named = sorted((e for e in by_element if e is not None), key=_natural)
    if not per_element or not named:
        return mark
    return f"{mark} [" + " ".join(f"{e} {MARKS.get(by_element[e], '?')}" for e in named) + "]"


def _natural(name: str) -> list:
    """Sort key putting E2 before E10."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", name)]


def label(spec: NodeSpec) -> str:
    """`name [kind details]`, as its kind labels it."""
    return f"{spec.name} {NODE_KINDS[spec.kind].label(spec)}"


def render(doc: TreeDocument, run_dir: Path | None = None) -> str:
    """The tree as indented text; with `run_dir`, each node marked with its final status."""
    statuses = final_statuses(run_dir) if run_dir else {}
    lines = [f"{doc.name}  ({doc.path}, {doc.tick_hz:g} Hz, scene {doc.scene})"]

    def walk(spec: NodeSpec, prefix: str, last: bool, top: bool, per_element: bool = False):
        mark = _marks(statuses.get(spec.path, {}), per_element) if run_dir else ""
        branch = "" if top else ("└── " if last else "├── ")
        lines.append(f"{prefix}{branch}{mark + ' ' if mark else ''}{label(spec)}")
        child_prefix = prefix + ("" if top else ("    " if last else "│   "))
        for i, child in enumerate(spec.children):
            walk(child, child_prefix, i == len(spec.children) - 1, False,
                 per_element or spec.kind == "for_each_element")

    walk(doc.root, "", True, True)
    if run_dir:
        lines.append("legend: ✔ success  ✘ failure  * running  ■ stopped while running  - not ticked (or reset); [E1 ✔ E2 ✘]: the last status for each element")
    return "\n".join(lines)
