"""Bad input to each `fvtree` command: a located one-line message on stderr and exit code 2."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from assembly.cli import main

TREES = Path(__file__).resolve().parents[1] / "trees"
BAD_SKILL = "version: 1\nname: t\nroot:\n  skill: mvoe_to\n"


def fails_with(argv: list[str], capsys) -> str:
    """Run the command, expect exit code 2 and no traceback; return stderr."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.strip() and "Traceback" not in err and "rerun with --debug" not in err
    return err


def usage_error(argv: list[str], capsys) -> str:
    """argparse rejects the arguments themselves (exit code 2); return stderr."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    return capsys.readouterr().err


def test_validate(tree_file, tmp_path, capsys):
    err = fails_with(["validate", str(tmp_path / "nope.yaml")], capsys)
    assert "nope.yaml: no such file" in err
    err = fails_with(["validate", str(tree_file(BAD_SKILL))], capsys)
    assert "tree.yaml:4: mvoe_to: unknown skill 'mvoe_to' (did you mean 'move_to'?)" in err
    err = fails_with(["validate", str(tree_file("version: 1\nname: [t\n"))], capsys)
    assert "tree.yaml:3: malformed YAML" in err
    err = fails_with(["validate", str(tree_file("- just a list\n"))], capsys)
    assert "tree.yaml:1: a tree file is a YAML mapping" in err


def test_validate_reports_every_file(tree_file, capsys):
    good, bad = str(TREES / "hold.yaml"), str(tree_file(BAD_SKILL))
    assert main(["validate", bad, good]) == 2
    captured = capsys.readouterr()
    assert "hold.yaml: ok" in captured.out and "unknown skill" in captured.err


def test_subtree_param_default_of_the_wrong_type(tree_file, capsys):
    text = ("version: 1\nname: t\nsubtrees:\n  lift:\n    params:\n      height: {type: float, default: high}\n"
            "    root: {skill: move_to, name: up, params: {offset: [0, 0, $height]}}\n"
            "root: {subtree: lift, name: go}\n")
    err = fails_with(["validate", str(tree_file(text))], capsys)
    assert "tree.yaml:6: subtrees/lift: param 'height': default: expected float, got str 'high'" in err


def test_choice_param_message_keeps_its_quotes(tree_file, capsys):
    text = "version: 1\nname: t\nroot: {skill: in_hand_rot, name: r, params: {variant: slipp}}\n"
    err = fails_with(["validate", str(tree_file(text))], capsys)
    assert "param 'variant': 'slipp' is not one of" in err and err.rstrip().endswith("'")


def test_show(tree_file, tmp_path, capsys):
    fails_with(["show", str(tree_file(BAD_SKILL))], capsys)
    err = fails_with(["show", str(TREES / "hold.yaml"), "--run", str(tmp_path)], capsys)
    assert f"{tmp_path}/transitions.jsonl: no transition log (is {tmp_path} a run directory?)" in err
    (tmp_path / "transitions.jsonl").write_text('{"node": "a", "to": "SUCCESS"}\nnot json\n')
    err = fails_with(["show", str(TREES / "hold.yaml"), "--run", str(tmp_path)], capsys)
    assert "transitions.jsonl:2: not a transition record" in err


def test_run(tree_file, tmp_path, capsys):
    runs = ["--runs-dir", str(tmp_path / "runs")]
    err = fails_with(["run", str(tree_file(BAD_SKILL)), *runs], capsys)
    assert "unknown skill 'mvoe_to'" in err
    scene = (TREES / "hold.yaml").read_text().replace("scene: hold", "scene: hodl")
    err = fails_with(["run", str(tree_file(scene)), *runs], capsys)
    assert "tree.yaml:5: cell.scene: no simulated scene 'hodl' (did you mean 'hold'?)" in err
    err = fails_with(["run", str(TREES / "hold.yaml"), "--cell", "nocell", *runs], capsys)
    assert "no such cell file" in err
    err = fails_with(["run", str(TREES / "assembly.yaml"), "--resume", str(tmp_path), *runs], capsys)
    assert f"{tmp_path}: not a run directory" in err
    for bad in (["--max-time", "0"], ["--max-time", "nan"], ["--max-time", "inf"], ["--seed", "-1"],
                ["--estop-at", "soon"]):  # nan was taken as "no limit"
        assert "fvtree run: error: argument" in usage_error(["run", str(TREES / "hold.yaml"), *bad], capsys)


def test_files_that_cannot_be_written(tmp_path, capsys):
    err = fails_with(["schema", "--out", str(tmp_path / "no" / "dir" / "tree.schema.json")], capsys)
    assert "tree.schema.json: No such file or directory" in err
    (tmp_path / "a_file").write_text("")
    err = fails_with(["bench", "ticks", "--quick", "--out", str(tmp_path / "a_file")], capsys)
    assert "a_file: File exists" in err


def test_record_and_train(tree_file, tmp_path, capsys):
    err = fails_with(["record", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "r.npz")], capsys)
    assert "nope.yaml: no such file" in err
    err = usage_error(["record", str(TREES / "record_press.yaml"), "--out", "r.npz", "--runs", "0"], capsys)
    assert "argument --runs: must be >= 1, got 0" in err
    err = usage_error(["train", "force", str(tmp_path / "nope.npz"), "--out", "m.joblib"], capsys)
    assert "argument data: no such file" in err


def test_unknown_command_and_choices(capsys):
    assert "invalid choice" in usage_error(["bench", "nope"], capsys)
    assert "invalid choice" in usage_error(["flyto"], capsys)


BOMB = "version: 1\nname: bomb\na: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n" + "".join(
    f"{b}: &{b} [{', '.join([f'*{a}'] * 9)}]\n" for a, b in zip("abcdefgh", "bcdefghi")) + "root: {skill: move_to}\n"


@pytest.mark.parametrize("content, message", [
    (BOMB, "tree.yaml: more than 200000 values once its aliases are expanded"),
    ("version: 1\nname: deep\nroot: " + "[" * 3000 + "]" * 3000 + "\n", "tree.yaml:3: nested more than 100 levels deep"),
    (b"version: 1\nname: t\xff\n", "tree.yaml:2: not UTF-8 text: byte 0xff"),
    ("version: 1\nname: t\x01\n", "tree.yaml:2: malformed YAML: character #x0001"),
    ("version: 1\nname: t\n? [a, b]\n: 1\n", "tree.yaml:3: a mapping key must be a plain value"),
    ("version: 1\nname: t\nroot: {skill: {}}\n", "tree.yaml:3: /: 'skill' takes a type name, got {}"),
    ("version: 1\nname: t\nroot: {skill: [move_to]}\n", "tree.yaml:3: /: 'skill' takes a type name"),
    ("version: 1\nname: t\nroot: {skill: move_to, params: {speed: .nan}}\n", "tree.yaml:3: '.nan' is not a finite number"),
    ("version: 1\nname: t\nrec: &r [*r]\nroot: {skill: move_to}\n", "tree.yaml:3: an alias refers to the node"),
    ("version: 1\nname: t\n" + "x" * (1 << 20), "tree.yaml: larger than 1024 KiB"),
])
def test_hostile_tree_files_give_located_errors_quickly(tmp_path, capsys, content, message):
    path = tmp_path / "tree.yaml"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    started = time.thread_time()  # CPU time: what an alias bomb or deep nesting would burn, whatever the load
    assert message in fails_with(["validate", str(path)], capsys)
    assert time.thread_time() - started < 5.0  # well under a second


def test_directories_and_fifos_are_refused_without_opening_them(tmp_path, capsys):
    fifo = tmp_path / "design.json"
    os.mkfifo(fifo)  # opening it for reading would block until a writer comes
    (tmp_path / "dir.yaml").mkdir()
    assert "design.json: not a regular file: a FIFO" in fails_with(["validate", str(fifo)], capsys)
    assert "dir.yaml: not a regular file: a directory" in fails_with(["validate", str(tmp_path / "dir.yaml")], capsys)
    tree = f"version: 1\nname: t\ndesign: {fifo}\nroot: {{skill: move_to}}\n"
    assert "not a regular file: a FIFO" in fails_with(["validate", str(write(tmp_path / "t.yaml", tree))], capsys)


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_validate_a_design_file(tmp_path, capsys):
    good = TREES / "design" / "two_bays.json"
    assert main(["validate", str(good)]) == 0
    assert "ok (design, 2 elements on 2 plates)" in capsys.readouterr().out
    text = good.read_text()
    for change, message in [
        (('"span": 1.0', '"span": 1.0, "sim_lod": 2'), "design.json:6: plate 'P1': unknown field 'sim_lod'"),
        (('"status": "planned"', '"statu": "planned"'), "element 'E1': unknown field 'statu' (did you mean 'status'?)"),
        (('"status": "planned"', '"status": "plced"'), "field 'status' must be one of planned, placing, placed"),
        (('"span": 1.0', '"span": NaN'), "plate 'P1': field 'span' must be number (finite), got nan"),
        (('"width": 0.2', '"width": -0.2'), "plate 'P1': field 'width' must be above 0"),
        (('"mass": 0.4', '"mass": Infinity'), "element 'E1': field 'mass' must be number (finite)"),
        (('"nodes": [', '"nodes": [1, '), "design.json:5: design: field 'nodes' item 0 must be object"),
        (('{"source": "E1", "target": "E2"}', '{"source": "E1", "target": "E9"}'), "edge target 'E9' is not a node"),
        (('"directed": true,', '"directed": true,\n "directed": true,'), "design.json:3: duplicate key 'directed'"),
        (('"nodes"', '"nodes'), "design.json:5: malformed JSON"),
    ]:
        assert change[0] in text
        err = fails_with(["validate", str(write(tmp_path / "design.json", text.replace(*change, 1)))], capsys)
        assert message in err, err
    deep = write(tmp_path / "deep.json", "[" * 100_000 + "]" * 100_000)
    assert "deep.json: malformed JSON: nested too deeply" in fails_with(["validate", str(deep)], capsys)


def test_validate_a_cell_file(tmp_path, capsys):
    for name in ("sim", "emulated", "emulated_shadow", "ur_robotiq"):
        assert main(["validate", "--cell", name]) == 0
    assert "kind sim" in capsys.readouterr().out
    sim = (Path(__file__).resolve().parents[1] / "drivers" / "cells" / "sim.yaml").read_text()
    for change, message in [
        (("max_force: 120.0", "max_force: .nan"), "cell.yaml:9: '.nan' is not a finite number"),
        (("home: [0.0, 0.0, 0.5,", "home: [0.0, 0.0, 1.5,"), "cell.yaml:4: home: position [0.0, 0.0, 1.5] is outside the safety box"),
        (("home: [0.0, 0.0, 0.5,", "home: [0.0, 0.0, zero,"), "cell.yaml:4: home: must be a pose of 6 finite numbers"),
        (("gripper:", "griper:"), "cell.yaml:12: griper: unknown field (did you mean 'gripper'?)"),
        (("kind: sim", "kind: [sim]"), "cell.yaml:2: kind: must be a name"),
    ]:
        assert change[0] in sim
        err = fails_with(["validate", "--cell", str(write(tmp_path / "cell.yaml", sim.replace(*change, 1)))], capsys)
        assert message in err, err


def test_element_ids_are_checked_against_the_design(tree_file, capsys, shipped_designs_allowed):
    design = TREES / "design" / "two_bays.json"
    text = (f"version: 1\nname: t\ndesign: {design}\nroot:\n  for_each_element: each\n  elements: [E1, E9]\n"
            "  child: {skill: locate_element}\n")
    err = fails_with(["validate", str(tree_file(text))], capsys)
    assert "tree.yaml:6: each: element 'E9' is not in the design (its elements: E1, E2)" in err
