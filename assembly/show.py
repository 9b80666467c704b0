"""`fvtree show`: the tree as text, each node with its kind, params and (from a run's
transition log) its last status."""

from __future__ import annotations

import json
from pathlib import Path

from assembly.language import NodeSpec
from assembly.loader import TreeDocument

MARKS = {"SUCCESS": "✔", "FAILURE": "✘", "RUNNING": "*", "INVALID": "-"}


def final_statuses(run_dir: Path) -> dict[str, str]:
    """Last status of every node path in a run's transitions.jsonl."""
    statuses: dict[str, str] = {}
    log = run_dir / "transitions.jsonl"
    if not log.exists():
        raise FileNotFoundError(f"{log}: no transition log (is {run_dir} a run directory?)")
    with open(log) as f:
        for line in f:
            if line.strip():
                record = json.loads(line)
                statuses[record["node"]] = record["to"]
    return statuses


def _label(spec: NodeSpec) -> str:
    a = spec.args
    if spec.kind == "skill":
        params = ", ".join(f"{k}={v}" for k, v in a.get("params", {}).items())
        return f"{spec.name} [skill {spec.type}]" + (f" ({params})" if params else "")
    if spec.kind in ("sequence", "selector"):
        return f"{spec.name} [{spec.kind}, memory={str(a['memory']).lower()}]"
    if spec.kind == "condition":
        return f"{spec.name} [condition {a['key']} {a['op']} {a['value']!r}]"
    if spec.kind == "guard":
        c = a["while"]
        return f"{spec.name} [guard while {c['key']} {c['op']} {c['value']!r}]"
    extra = {"retry": "attempts", "repeat": "times", "timeout": "seconds", "parallel": "policy"}.get(spec.kind)
    detail = f" {extra}={a[extra]}" if extra else ""
    kind = f"subtree {spec.type}" if spec.kind == "subtree" else spec.kind
    return f"{spec.name} [{kind}{detail}]"


def render(doc: TreeDocument, run_dir: Path | None = None) -> str:
    statuses = final_statuses(run_dir) if run_dir else {}
    lines = [f"{doc.name}  ({doc.path}, {doc.tick_hz:g} Hz, scene {doc.scene})"]

    def walk(spec: NodeSpec, prefix: str, last: bool, top: bool):
        mark = MARKS.get(statuses.get(spec.path, "INVALID"), "?") if run_dir else ""
        branch = "" if top else ("└── " if last else "├── ")
        lines.append(f"{prefix}{branch}{mark + ' ' if mark else ''}{_label(spec)}")
        child_prefix = prefix + ("" if top else ("    " if last else "│   "))
        for i, child in enumerate(spec.children):
            walk(child, child_prefix, i == len(spec.children) - 1, False)

    walk(doc.root, "", True, True)
    if run_dir:
        lines.append("legend: ✔ success  ✘ failure  * running  - not ticked")
    return "\n".join(lines)
