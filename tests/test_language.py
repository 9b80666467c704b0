"""The YAML tree language: what loads, and the message each kind of bad input gets."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

from assembly.cli import main
from assembly.errors import TreeErrors
from assembly.language.build import build
from assembly.language.reader import load_tree

TREES = Path(__file__).resolve().parents[1] / "trees"

GOOD = """\
version: 1
name: t
root:
  sequence: root
  memory: true
  children:
    - {skill: move_to, name: up, params: {offset: [0, 0, 0.1]}}
    - {condition: near, key: "/robot/pose[2]", op: gt, value: 0.1}
"""


def errors_of(text: str, tree_file, **others) -> list[str]:
    path = tree_file(textwrap.dedent(text), **others)
    with pytest.raises(TreeErrors) as exc:
        load_tree(path)
    return [str(e) for e in exc.value.errors]


def test_good_tree_builds_with_stable_paths():
    doc = load_tree(text=GOOD, name="good.yaml")
    built = build(doc)
    assert sorted(built.nodes) == ["root", "root/near", "root/up"]
    assert built.path_of(built.nodes["root/up"]) == "root/up"
    assert built.nodes["root/up"].p.offset == [0.0, 0.0, 0.1]


def test_shipped_trees_validate():
    for path in sorted(TREES.glob("*.yaml")):
        load_tree(path)  # raises on any problem


def test_malformed_yaml_names_the_line(tree_file):
    [msg] = errors_of("version: 1\nname: t\nroot: {sequence: r, memory: true\n", tree_file)
    assert "tree.yaml:4" in msg and "malformed YAML" in msg


def test_unknown_kind_with_hint(tree_file):
    [msg] = errors_of(GOOD.replace("sequence: root", "sequense: root"), tree_file)
    assert "tree.yaml:4" in msg and "unknown node kind 'sequense'" in msg and "did you mean 'sequence'" in msg


def test_unknown_skill_with_hint_and_path(tree_file):
    [msg] = errors_of(GOOD.replace("skill: move_to", "skill: mvoe_to"), tree_file)
    assert ":7: root/up: unknown skill 'mvoe_to'" in msg and "did you mean 'move_to'" in msg


@pytest.mark.parametrize("look_alike", ["gr\u0430sp", "grasp\u200b"])  # a Cyrillic a; a zero-width space
def test_a_node_name_that_prints_like_another_is_refused(tree_file, look_alike):
    """Before: `grasp` beside `grasp\\u200b` were two names that print identically."""
    [msg] = errors_of(GOOD.replace("name: up", f'name: "{look_alike}"'), tree_file)
    escaped = look_alike.encode("ascii", "backslashreplace").decode()
    assert f":7: root: node name '{escaped}' holds a character that is not printable ASCII" in msg, msg


def test_unknown_param(tree_file):
    [msg] = errors_of(GOOD.replace("offset:", "ofset:"), tree_file)
    assert "root/up: unknown param 'ofset' for skill 'move_to'" in msg and "did you mean 'offset'" in msg


def test_mistyped_param(tree_file):
    [msg] = errors_of(GOOD.replace("[0, 0, 0.1]", "up"), tree_file)
    assert "param 'offset': expected a list of numbers" in msg


def test_value_out_of_range(tree_file):
    [msg] = errors_of(GOOD.replace("params: {offset: [0, 0, 0.1]}", "params: {offset: [0, 0, 0.1], speed: 5}"), tree_file)
    assert "param 'speed': 5.0 is above the maximum 1.0 m/s" in msg


def test_missing_memory(tree_file):
    [msg] = errors_of(GOOD.replace("  memory: true\n", ""), tree_file)
    assert "missing required field 'memory' for a sequence" in msg and ":4:" in msg


def test_duplicate_names(tree_file):
    [msg] = errors_of(GOOD.replace("condition: near", "condition: up"), tree_file)
    assert "duplicate name 'up' among the children of root" in msg and "first used on line 7" in msg


def test_unknown_blackboard_key(tree_file):
    [msg] = errors_of(GOOD.replace("/robot/pose[2]", "/robot/pos[2]"), tree_file)
    assert "unknown blackboard key '/robot/pos'" in msg and "did you mean '/robot/pose'" in msg


def test_several_errors_are_all_reported(tree_file):
    msgs = errors_of(GOOD.replace("skill: move_to", "skill: nope").replace("op: gt", "op: bigger"), tree_file)
    assert len(msgs) == 2


SUBTREE = """\
version: 1
name: t
subtrees:
  lift:
    params: {height: float}
    root: {skill: move_to, name: up, params: {offset: [0, 0, $height]}}
root:
  sequence: root
  memory: true
  children:
    - {subtree: lift, name: first, params: {height: 0.1}}
"""


def test_subtree_params_are_substituted():
    built = build(load_tree(text=SUBTREE, name="s.yaml"))
    assert built.nodes["root/first/up"].p.offset == [0.0, 0.0, 0.1]


def test_missing_subtree(tree_file):
    [msg] = errors_of(SUBTREE.replace("subtree: lift", "subtree: lfit"), tree_file)
    assert "unknown subtree 'lfit'" in msg and "did you mean 'lift'" in msg and ":11:" in msg


def test_subtree_param_type_and_missing(tree_file):
    [msg] = errors_of(SUBTREE.replace("{height: 0.1}", "{height: high}"), tree_file)
    assert "param 'height': expected float" in msg
    [msg] = errors_of(SUBTREE.replace(", params: {height: 0.1}", ""), tree_file)
    assert "missing param 'height' for subtree 'lift'" in msg


def test_recursive_subtree(tree_file):
    text = """\
    version: 1
    name: t
    subtrees:
      a: {root: {subtree: b, name: to_b}}
      b: {root: {subtree: a, name: to_a}}
    root: {subtree: a, name: start}
    """
    msgs = errors_of(text, tree_file)
    assert any("recursive subtree: a -> b -> a" in m for m in msgs)


def test_include_and_include_errors(tree_file):
    inc = "version: 1\nsubtrees:\n  lift:\n    root: {skill: move_to, name: up, params: {offset: [0, 0, 0.1]}}\n"
    path = tree_file("version: 1\nname: t\ninclude: [sub/lift.yaml]\nroot: {subtree: lift, name: go}\n",
                     **{"sub__lift.yaml": inc})
    assert "go/up" in build(load_tree(path)).nodes
    bad = inc.replace("move_to", "move_too")
    path = tree_file("version: 1\nname: t\ninclude: [sub/lift.yaml]\nroot: {subtree: lift, name: go}\n",
                     **{"sub__lift.yaml": bad})
    with pytest.raises(TreeErrors) as exc:
        load_tree(path)
    assert "lift.yaml:4" in str(exc.value) and "unknown skill 'move_too'" in str(exc.value)


def test_missing_design_file(tree_file):
    text = GOOD.replace("name: t\n", "name: t\ndesign: nowhere.json\n")
    [msg] = errors_of(text, tree_file)
    assert "nowhere.json" in msg and "no such file" in msg


def test_design_with_a_cycle(tree_file):
    design = json.loads((TREES / "design" / "two_bays.json").read_text())
    design["edges"].append({"source": "E2", "target": "E1"})
    text = GOOD.replace("name: t\n", "name: t\ndesign: d.json\n")
    [msg] = errors_of(text, tree_file, **{"d.json": json.dumps(design)})
    assert "precedence graph has a cycle" in msg and "E1" in msg and "E2" in msg


def test_for_each_element_needs_a_design(tree_file):
    text = "version: 1\nname: t\nroot:\n  for_each_element: all\n  child: {skill: estop_guard}\n"
    [msg] = errors_of(text, tree_file)
    assert "for_each_element needs a design model" in msg


def test_cli_validate_exit_codes(tree_file, capsys):
    assert main(["validate", str(TREES / "assembly.yaml")]) == 0
    bad = tree_file(GOOD.replace("skill: move_to", "skill: mvoe_to"))
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "unknown skill 'mvoe_to'" in err and "Traceback" not in err


def test_subtree_params_reach_decorator_fields():
    text = """\
version: 1
name: t
subtrees:
  again:
    params: {count: int, limit: {type: float, default: 2.0}}
    root:
      repeat: loop
      times: $count
      child: {timeout: limit, seconds: $limit, child: {skill: move_to, name: up, params: {offset: [0, 0, 0.01]}}}
root: {subtree: again, name: thrice, params: {count: 3}}
"""
    built = build(load_tree(text=text, name="s.yaml"))
    assert built.nodes["thrice/loop"].num_success == 3
    assert built.nodes["thrice/loop/limit"].duration == 2.0


def test_a_node_that_is_not_a_mapping_is_located(tree_file):
    [msg] = errors_of(GOOD.replace("    - {condition: near", "    - near\n    - {condition: near"), tree_file)
    assert "tree.yaml:8: root: a node must be a mapping, got 'near'" in msg


def test_a_skill_type_must_be_a_name(tree_file):
    [msg] = errors_of(GOOD.replace("skill: move_to, name: up", "skill: [move_to], name: up"), tree_file)
    assert "tree.yaml:7: root: 'skill' takes a type name, got ['move_to']" in msg


def test_unprintable_characters_and_binary_files(tree_file):
    [msg] = errors_of("version: 1\nname: t\x07\n", tree_file)
    assert "tree.yaml:2: malformed YAML: character #x0007" in msg
    path = tree_file("")
    path.write_bytes(b"\xff\xfe\x00binary")
    with pytest.raises(TreeErrors, match="tree.yaml:1: not UTF-8 text: byte 0xff"):
        load_tree(path)


def test_a_missing_design_points_at_the_tree_line(tree_file):
    [msg] = errors_of(GOOD.replace("name: t\n", "name: t\ndesign: nowhere.json\n"), tree_file)
    assert "tree.yaml:3: design " in msg and "nowhere.json: no such file" in msg
