"""Substitution by path: replace any node of a validated tree (and what is under it) with a test
double, by its path or a glob over paths, for tree authors' tests and `fvtree run --substitute`.

A rule is `PATTERN=SPEC`. PATTERN is a node path (`main/assemble/elements/build/prop/pick/pick_once/grasp`)
or an `fnmatch` glob over paths whose `*` also crosses `/` (`*/grasp`). SPEC is `success`, `failure`,
`running` (for ever), `running:N:success` / `running:N:failure` (RUNNING for N ticks, then the
status), or `skill:TYPE` / `skill:TYPE:{json params}` (another skill, its params checked against its
declaration). A rules file is JSON: `{"PATTERN": SPEC, ...}`, where a skill SPEC may also be
`{"skill": TYPE, "params": {...}}`. The first rule matching a node replaces it; a rule matching no
node is an error, as is a SPEC that does not parse, both with exit code 2.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, replace
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

from assembly.errors import TreeError, TreeErrors
from assembly.language.reader import TreeDocument
from assembly.language.validator import NodeSpec
from behaviours.skill_kit.registry import SKILLS
from fvfiles.errors import FvtreeError, did_you_mean
from fvfiles.yaml_source import read_text

_STATUS = re.compile(r"^(success|failure|running)$|^running:(\d+):(success|failure)$")
SPEC_HINT = "use success, failure, running, running:N:success, running:N:failure or skill:TYPE[:{json params}]"


class SubstitutionError(FvtreeError):
    """A rule that does not parse or matches no node; names where the rule came from."""


@dataclass(frozen=True)
class Rule:
    """One substitution: which nodes (`pattern`), by what (`spec`), and where the rule was given."""

    pattern: str
    spec: str | dict
    source: str = "--substitute"

    def double(self, spec: NodeSpec) -> NodeSpec:
        """The NodeSpec of the double standing in for `spec` (same name, path and place)."""
        note = f"substituted for {spec.kind} {spec.type or spec.name} by {self.describe()}"
        common: dict[str, Any] = {"children": [], "file": spec.file, "line": spec.line}
        if isinstance(self.spec, dict):
            params = _skill_params(self.spec["skill"], self.spec.get("params") or {}, self.source)
            return replace(spec, kind="skill_double", type=self.spec["skill"],
                           args={"params": params, "note": note}, **common)
        m = _STATUS.match(self.spec)
        assert m is not None  # a status double: `_spec` matched it when the rule was read
        running, final = (0, m.group(1)) if m.group(1) else (int(m.group(2)), m.group(3))
        if final == "running":
            running = 1 << 62
        return replace(spec, kind="status_double", type="", args={"running_ticks": running, "final": final,
                                                                     "note": note}, **common)

    def describe(self) -> str:
        if isinstance(self.spec, dict):
            params = json.dumps(self.spec.get("params") or {}, separators=(",", ":"))
            return f"skill {self.spec['skill']} {params}"
        return self.spec


def _skill_params(skill: str, params: Any, source: str) -> dict:
    cls = SKILLS.get(skill)
    if cls is None:
        raise SubstitutionError(f"unknown skill {skill!r}", source, hint=did_you_mean(skill, SKILLS) or
                                "run 'fvtree skills' to list them")
    if not isinstance(params, dict):
        raise SubstitutionError(f"params of skill {skill!r} must be a JSON object, got {params!r}", source)
    try:
        return cls.resolve_params(params)
    except KeyError as exc:
        raise SubstitutionError(f"unknown param {exc.args[0]!r} for skill {skill!r}", source,
                                hint=did_you_mean(exc.args[0], cls.PARAMS)) from None
    except ValueError as exc:
        raise SubstitutionError(f"skill {skill!r}: {exc}", source) from None


def _spec(value: Any, source: str) -> str | dict:
    """A checked SPEC from a string or a `{"skill", "params"}` object."""
    if isinstance(value, str) and value.startswith("skill:"):
        skill, _, params = value[len("skill:"):].partition(":")
        try:
            value = {"skill": skill, "params": json.loads(params) if params else {}}
        except json.JSONDecodeError as exc:
            raise SubstitutionError(f"params of {value!r} are not JSON: {exc.msg}", source) from None
    if isinstance(value, dict):
        if set(value) - {"skill", "params"} or not isinstance(value.get("skill"), str):
            raise SubstitutionError(f"a skill double is {{\"skill\": TYPE, \"params\": {{...}}}}, got {value!r}", source)
        _skill_params(value["skill"], value.get("params") or {}, source)
        return value
    if not isinstance(value, str) or not _STATUS.match(value):
        raise SubstitutionError(f"cannot read the double {value!r}", source, hint=SPEC_HINT)
    return value


def parse_rule(text: str, source: str = "--substitute") -> Rule:
    """A rule from `PATTERN=SPEC` (the command line's form)."""
    pattern, sep, spec = text.partition("=")
    if not sep or not pattern:
        raise SubstitutionError(f"expected PATH=SPEC, got {text!r}", source, hint=SPEC_HINT)
    return Rule(pattern, _spec(spec, source), source)


def load_rules(path: str | Path) -> list[Rule]:
    """The rules of a JSON file `{"PATTERN": SPEC, ...}`, in file order."""
    name = str(path)
    try:
        data = json.loads(read_text(path))
    except json.JSONDecodeError as exc:
        raise SubstitutionError(f"not JSON: {exc.msg}", name, exc.lineno) from None
    if not isinstance(data, dict):
        raise SubstitutionError('a rules file is a JSON object {"PATH or glob": SPEC, ...}', name)
    return rules_from(data, name)


def rules_from(given: dict[str, Any] | list[Rule], source: str) -> list[Rule]:
    """Rules from `{PATTERN: SPEC}` (checked) or a list of rules (as they are)."""
    if isinstance(given, dict):
        return [Rule(pattern, _spec(spec, f"{source}: {pattern}"), source) for pattern, spec in given.items()]
    return list(given)


def substitute(doc: TreeDocument, rules: list[Rule]) -> tuple[TreeDocument, list[dict]]:
    """The document with every node a rule matches replaced by its double (outermost match
    first: what is under a replaced node goes with it), and the substitutions made (path, what
    was there, the double, the rule's source). A rule matching no node raises TreeErrors."""
    if not rules:
        return doc, []
    made: list[dict] = []
    used: set[int] = set()
    paths: list[str] = []

    def visit(spec: NodeSpec) -> NodeSpec:
        paths.append(spec.path)
        for i, rule in enumerate(rules):
            if spec.path == rule.pattern or fnmatchcase(spec.path, rule.pattern):
                used.add(i)
                made.append({"path": spec.path, "was": f"{spec.kind} {spec.type or spec.name}",
                             "double": rule.describe(), "rule": rule.pattern, "source": rule.source})
                return rule.double(spec)
        return replace(spec, children=[visit(c) for c in spec.children])

    root = visit(doc.root)
    unused = [r for i, r in enumerate(rules) if i not in used]
    if unused:
        raise TreeErrors([TreeError(f"substitution {r.pattern!r} matches no node in {doc.path}", r.source, None, None,
                                    did_you_mean(r.pattern, paths) or "node paths are shown by 'fvtree show'")
                          for r in unused])
    return replace(doc, root=root), made
