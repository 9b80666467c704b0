"""The node-kind table: how to add a node kind, and that every part of the language reads the table.

A new kind is one entry in `assembly.language.kinds.NODE_KINDS`. The test below registers a
`succeeder` (its child's failure becomes success) and shows that the one entry is enough for the
validator, `build()`, ticking, `tree_schema()` and `fvtree show`.
"""

from __future__ import annotations

from pathlib import Path

import jsonschema
import py_trees
import pytest
import yaml
from py_trees.common import Status

from assembly.errors import TreeErrors
from assembly.language.build import build
from assembly.language.kinds import NODE, NODE_KINDS
from assembly.language.reader import load_tree
from assembly.language.schema import tree_schema
from assembly.language.validator import NodeKind
from assembly.outcome.outline import render
from behaviours.skill_kit.registry import SKILLS

SUCCEEDER = NodeKind(
    doc="succeeds when its child fails (a failing check that must not stop the sequence)",
    fields={"child": NODE},
    required=frozenset({"child"}),
    check=lambda validator, spec, node, scope: validator.children(spec, node, scope, "child"),
    build=lambda spec, kids: py_trees.decorators.FailureIsSuccess(name=spec.name, child=kids[0]),
)

TREE = """\
version: 1
name: t
root:
  succeeder: optional
  child: {condition: placed, key: /task/asbuilt, op: exists}
"""


@pytest.fixture
def succeeder(monkeypatch):
    monkeypatch.setitem(NODE_KINDS, "succeeder", SUCCEEDER)


def test_a_new_kind_is_one_table_entry(succeeder):
    built = build(load_tree(text=TREE, name="t.yaml"))
    assert sorted(built.nodes) == ["optional", "optional/placed"]
    built.root.tick_once()  # /task/asbuilt is not set: the condition fails, the succeeder succeeds
    assert built.nodes["optional/placed"].status == Status.FAILURE
    assert built.root.status == Status.SUCCESS

    schema = tree_schema()
    assert any("succeeder" in v["properties"] for v in schema["$defs"]["node"]["oneOf"])
    jsonschema.Draft202012Validator(schema).validate(yaml.safe_load(TREE))

    assert "optional [succeeder]" in render(load_tree(text=TREE, name="t.yaml"))


def test_a_new_kind_is_validated_by_its_fields(succeeder):
    with pytest.raises(TreeErrors) as exc:
        load_tree(text=TREE.replace("  child:", "  chlid:"), name="t.yaml")
    messages = [str(e) for e in exc.value.errors]
    assert "t.yaml:5: optional: unknown field 'chlid' for a succeeder (did you mean 'child'?)" in messages
    assert "t.yaml:4: optional: missing required field 'child' for a succeeder" in messages


def test_without_its_entry_the_kind_is_unknown():
    with pytest.raises(TreeErrors) as exc:
        load_tree(text=TREE, name="t.yaml")
    assert "unknown node kind 'succeeder'" in str(exc.value)


@pytest.mark.parametrize("name", sorted(NODE_KINDS))
def test_every_kind_is_documented_and_in_the_schema(name):
    kind = NODE_KINDS[name]
    assert kind.doc and "\n" not in kind.doc
    assert kind.required <= set(kind.fields)
    variants = tree_schema()["$defs"]["node"]["oneOf"]
    assert any(name in v["properties"] for v in variants)


def test_a_required_field_must_be_a_field():
    with pytest.raises(ValueError, match="are not fields"):
        NodeKind("doc", {"child": NODE}, frozenset({"children"}), SUCCEEDER.check, SUCCEEDER.build)


def test_the_readme_documents_every_kind():
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    for name, kind in NODE_KINDS.items():
        assert f"`{name}: {kind.value}`" in readme, f"README's node-kind table lacks {name}"


def test_skill_params_are_checked_once_on_the_way_to_the_skill(monkeypatch):
    cls = SKILLS["move_to"]
    calls = []
    resolve = cls.resolve_params.__func__

    def counted(c, given):
        calls.append(given)
        return resolve(c, given)

    monkeypatch.setattr(cls, "resolve_params", classmethod(counted))
    text = """\
version: 1
name: t
subtrees:
  lift:
    params: {height: float}
    root: {skill: move_to, name: up, params: {offset: [0, 0, $height], speed: 0.05}}
root: {subtree: lift, name: go, params: {height: 1}}
"""
    built = build(load_tree(text=text, name="t.yaml"))
    assert calls == [{"offset": [0, 0, 1.0], "speed": 0.05}]  # the subtree's float, checked by the subtree
    assert built.nodes["go/up"].p.offset == [0.0, 0.0, 1.0] and built.nodes["go/up"].p.speed == 0.05
