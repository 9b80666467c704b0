"""`fvtree skills`, `fvtree schema` and `fvtree show`: generated from the skill declarations."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import yaml

from assembly.cli import main
from assembly.language.catalogue import describe_skills
from assembly.language.schema import tree_schema
from behaviours.skill_kit.registry import SKILLS

TREES = Path(__file__).resolve().parents[1] / "trees"


def test_skills_lists_every_skill_with_typed_params(capsys):
    assert main(["skills"]) == 0
    out = capsys.readouterr().out
    for name, cls in SKILLS.items():
        assert f"{name}: " in out
        for pname in cls.PARAMS:
            assert f"    {pname} (" in out
    d = describe_skills()["find_max_load"]
    assert d["params"]["speed"] == {**d["params"]["speed"], "type": "float", "unit": "m/s", "default": 0.03}
    assert "/task/best_pose" in d["writes"]


def test_schema_accepts_shipped_trees_and_rejects_typos():
    schema = tree_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    for path in [*TREES.glob("*.yaml"), *TREES.glob("subtrees/*.yaml")]:
        errors = list(validator.iter_errors(yaml.safe_load(path.read_text())))
        assert not errors, f"{path}: {errors[0].message}"
    bad = yaml.safe_load((TREES / "assembly.yaml").read_text())
    bad["root"]["children"][0]["params"] = {"speeed": 1}
    assert list(validator.iter_errors(bad))


def test_schema_command_writes_json(tmp_path):
    out = tmp_path / "tree.schema.json"
    assert main(["schema", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["title"] == "fvtree behaviour tree"


def test_show_prints_kinds_and_params(capsys):
    assert main(["show", str(TREES / "assembly.yaml")]) == 0
    out = capsys.readouterr().out
    assert "main [selector, memory=false]" in out
    assert "find_load [skill find_max_load] (span=[0.0, 1.0]" in out


def test_show_with_a_missing_run_dir_is_a_clear_error(tmp_path, capsys):
    assert main(["show", str(TREES / "assembly.yaml"), "--run", str(tmp_path)]) == 2
    assert "no transition log" in capsys.readouterr().err
