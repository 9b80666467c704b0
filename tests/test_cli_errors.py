"""Bad input to each `fvtree` command: a located one-line message on stderr and exit code 2."""

from __future__ import annotations

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
    for bad in (["--max-time", "0"], ["--seed", "-1"], ["--estop-at", "soon"]):
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
