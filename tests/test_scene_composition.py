"""Scenes that compose: each skill declares what the world must have for it (Skill.NEEDS) and each
scene what it has (Scene.PROVIDES); validate refuses a skill its scene lacks the thing for (a
descent until contact in the handover scene, which has no table: before, it "found" contact in the
air), `fvtree scenes` lists what each scene has and the skills it hosts, and the handover_press
scene (the handover scene's person above the press scene's scale) makes "receive by handover,
press on the scale, release" buildable, judged on both parts."""

from __future__ import annotations

from pathlib import Path

import pytest

from assembly.cli import main
from assembly.errors import TreeErrors
from assembly.language.affordances import supported_skills
from assembly.language.reader import load_tree, with_scene
from assembly.language.substitution import parse_rule
from assembly.outcome.verdict import TASK_FAILED
from assembly.run.options import RunOptions
from assembly.run.session import run_tree
from behaviours.skill_kit.base import WORLD_NEEDS
from behaviours.skill_kit.registry import SKILLS

TREES = Path(__file__).resolve().parents[1] / "trees"
RECEIVE_THEN_DESCEND = """version: 1
name: receive_descend
cell: {tick_hz: 30, scene: handover}
root:
  sequence: receive_press
  memory: true
  children:
    - {skill: handover, name: receive, params: {mode: receive}}
    - {skill: descend_until_contact, name: touch, params: {speed: 0.005, eps: 0.3}}
"""


def test_validate_refuses_a_skill_whose_world_the_scene_lacks(tmp_path, capsys):
    tree = tmp_path / "receive_descend.yaml"
    tree.write_text(RECEIVE_THEN_DESCEND)
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err
    assert (f"{tree}:9: receive_press/touch: skill 'descend_until_contact' needs a surface below the tool to touch "
            "(a table, the ground, a scale, a bowl's contents), which scene 'handover' does not have (it has: giver)") in err
    assert "scenes with surface: assembly, handover_press, press, stir" in err
    tree.write_text(RECEIVE_THEN_DESCEND.replace("scene: handover}", "scene: handover_press}"))
    assert main(["validate", str(tree)]) == 0


def test_another_scene_on_the_command_line_is_checked_the_same_way():
    doc = load_tree(TREES / "press_with_force.yaml")
    with pytest.raises(TreeErrors, match="skill 'descend_until_contact' needs a surface below the tool"):
        with_scene(doc, "hold")
    assert with_scene(doc, "stir").scene == "stir"


def test_every_skill_names_needs_the_scenes_know_and_every_shipped_tree_fits_its_scene():
    assert all(set(cls.NEEDS) <= set(WORLD_NEEDS) for cls in SKILLS.values())
    for tree in TREES.glob("*.yaml"):
        load_tree(tree)  # raises when a skill needs what its scene lacks
    assert "handover" not in supported_skills(frozenset({"leader"}))  # the FollowMe person leads, hands nothing
    assert supported_skills(None) == sorted(SKILLS)  # a plug-in scene that declares nothing hosts every skill


def test_fvtree_scenes_shows_what_each_scene_has_and_the_skills_it_hosts(capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    composite = out[out.index("handover_press:"):].split("\n\n")[0]
    assert "    has: giver, surface" in composite
    assert "handover" in composite and "press_with_force" in composite and "descend_until_contact" in composite
    assert "targets (set by the tree): press_force_N" in composite


def test_receive_press_release_runs_in_the_composed_scene():
    summary = run_tree(str(TREES / "handover_press.yaml"), RunOptions(runs_dir=None, quiet=True, plots=False))
    assert summary.status == "SUCCESS", (summary.message, summary.truth)
    assert summary.metrics["stick"] == "released, resting on the scale"
    assert summary.truth.tolerances["press_force_N"] == 5.0 and summary.truth.shortfalls == []


def test_the_composed_scene_judges_the_press_after_the_handover():
    summary = run_tree(str(TREES / "handover_press.yaml"), RunOptions(
        runs_dir=None, quiet=True, plots=False, substitutions=(parse_rule("receive_press_release/press=success"),)))
    assert summary.status == TASK_FAILED
    assert summary.truth.shortfalls[0].startswith("the scale never read 5 N +- 1 N for 0.25 s")
