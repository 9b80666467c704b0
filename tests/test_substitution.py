"""Substitution by path: any node of a tree replaced by a test double, by path or glob, in the test
harness and on `fvtree run`; what was replaced shows in the transition log and the summary."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from assembly.cli import main
from assembly.errors import TreeErrors
from assembly.language.reader import load_tree
from assembly.language.substitution import SubstitutionError, load_rules, parse_rule
from assembly.testing import TreeHarness
from drivers.cell_builders import load_cell

TREES = Path(__file__).resolve().parents[1] / "trees"
PICK = "main/assemble/elements/build/prop/pick"
GRASP = f"{PICK}/pick_once/grasp"


def assembly_harness(substitute) -> TreeHarness:
    doc = load_tree(TREES / "assembly.yaml")
    cell = load_cell("sim", doc.tick_hz, doc.scene, doc.design.scene_args(), seed=1)
    return TreeHarness.load(doc, cell, None, substitute)


def test_the_grasp_substituted_by_path_runs_for_its_ticks_then_succeeds():
    h = assembly_harness({"*/pick_once/scan": "success", GRASP: "running:3:success"})
    assert [s["path"] for s in h.substitutions] == [f"{PICK}/pick_once/scan", GRASP]
    assert h.substitutions[1]["was"] == "skill gentle_grasp"
    seen = []
    for _ in range(400):
        h.tick()
        seen.append(h.status(GRASP))
        if h.status(f"{PICK}") == "SUCCESS":
            break
    first = seen.index("RUNNING")
    assert seen[first:first + 4] == ["RUNNING", "RUNNING", "RUNNING", "SUCCESS"]
    assert "substituted for skill gentle_grasp by running:3:success (tick 4)" in h.feedback(GRASP)
    assert type(h.node(GRASP)).__name__ == "StatusDouble"  # gentle_grasp was never built
    h.halt()
    h.cell.close()


def test_a_failing_grasp_exhausts_the_retry_and_fails_the_tree():
    h = assembly_harness({"*/scan": "success", "*/grasp": "failure"})
    assert h.run_until_done(max_ticks=2000).name == "FAILURE"
    assert h.status(PICK) == "FAILURE" and h.status("main/assemble/elements/build/prop/lift") == "INVALID"
    h.cell.close()


def test_another_skill_with_params_stands_in_and_says_so():
    h = assembly_harness([parse_rule(GRASP + '=skill:move_to:{"offset": [0.0, 0.0, 0.01]}'),
                          parse_rule("*/scan=success")])
    for _ in range(400):
        h.tick()
        if h.status(GRASP) != "INVALID":
            break
    assert type(h.node(GRASP)).__name__ == "SubstitutedMoveTo"
    assert h.feedback(GRASP).startswith("substituted for skill gentle_grasp by skill move_to")
    h.halt()
    h.cell.close()


def test_a_substituted_subtree_takes_its_nodes_with_it():
    h = assembly_harness({"*/build": "running"})
    assert "main/assemble/elements/build" in h.tree.nodes
    assert not [p for p in h.tree.nodes if p.startswith("main/assemble/elements/build/")]
    h.tick(5)
    assert h.status("main/assemble/elements/build") == "RUNNING"
    h.cell.close()


@pytest.mark.parametrize("rule, message", [
    ("nowhere", "expected PATH=SPEC"),
    (f"{GRASP}=sucess", "cannot read the double"),
    (f"{GRASP}=running:x:success", "cannot read the double"),
    (f"{GRASP}=skill:grab", "unknown skill"),
    (f"{GRASP}=skill:move_to:{{\"ofset\": [0, 0, 1]}}", "unknown param 'ofset'"),
    (f"{GRASP}=skill:move_to:{{oops", "not JSON"),
])
def test_a_rule_that_does_not_parse_is_a_clear_error(rule, message):
    with pytest.raises(SubstitutionError, match=message):
        parse_rule(rule)


def test_a_rule_matching_no_node_names_the_closest_path():
    with pytest.raises(TreeErrors, match="matches no node.*did you mean"):
        assembly_harness({"main/assemble/elements/build/prop/pick/pick_once/grap": "success"})


def test_run_with_substitutions_logs_and_summarises_them(tmp_path, capsys):
    rules = tmp_path / "rules.json"
    rules.write_text(json.dumps({"*/grasp": "failure"}))
    code = main(["run", str(TREES / "press_release.yaml"), "--runs-dir", str(tmp_path), "--no-plots",
                 "--no-record", "--substitute", "press_release/touch=success", "--substitute-file", str(rules)])
    assert code == 1
    out = capsys.readouterr().out
    assert "substituted: press_release/grasp (skill gentle_grasp) by failure" in out
    run_dir = next(p for p in tmp_path.iterdir() if p.is_dir())
    summary = json.loads((run_dir / "summary.json").read_text())
    assert [(s["path"], s["double"], s["source"]) for s in summary["substitutions"]] == [
        ("press_release/grasp", "failure", str(rules)), ("press_release/touch", "success", "--substitute")]
    log = [json.loads(line) for line in (run_dir / "transitions.jsonl").read_text().splitlines()]
    assert any(e["node"] == "press_release/grasp" and e["to"] == "FAILURE" and "substituted" in e["feedback"]
               for e in log)


def test_a_rules_file_must_be_an_object(tmp_path):
    bad = tmp_path / "r.json"
    bad.write_text('["*/grasp=failure"]')
    with pytest.raises(SubstitutionError, match="JSON object"):
        load_rules(bad)
    assert main(["run", str(TREES / "hold.yaml"), "--runs-dir", str(tmp_path), "--substitute-file", str(bad)]) == 2
