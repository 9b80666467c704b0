"""Every scene's verdict judges its task: for each simulated scene a tree that ends SUCCESS
without doing the task (a hold that never closes the fingers, a press replaced by `success`, a
FollowMe cut short, a handover never received, a turn short of its target, a stick left off
hanging, a stir that never dips) ends TASK_FAILED naming the shortfall; a target the tree leaves
unset is reported as not judged. The shipped demo trees still end SUCCESS (tests/test_demos.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from assembly.language.substitution import parse_rule
from assembly.outcome.verdict import TASK_FAILED
from assembly.run.options import RunOptions
from assembly.run.session import run_tree

TREES = Path(__file__).resolve().parents[1] / "trees"
OVER_BOWL = "[0.0, 0.3, 0.5, 3.141593, 0.0, 0.0]"


def _run(tmp_path: Path, scene: str, children: list[str], tolerances: str = "", **options):
    """Run a sequence of `children` (YAML flow nodes) on `scene`."""
    cell = f"{{tick_hz: 30, scene: {scene}" + (f", tolerances: {tolerances}" if tolerances else "") + "}"
    body = "\n".join(f"    - {child}" for child in children)
    tree = tmp_path / "failed.yaml"
    tree.write_text(f"version: 1\nname: failed\ncell: {cell}\nroot:\n  sequence: failed\n  memory: true\n"
                    f"  children:\n{body}\n")
    return run_tree(str(tree), RunOptions(runs_dir=None, quiet=True, plots=False, **options))


def _failed(summary, shortfall: str) -> None:
    assert summary.status == TASK_FAILED and summary.tree_status == "SUCCESS", (summary.status, summary.message)
    assert any(shortfall in s for s in summary.truth.shortfalls), summary.truth.shortfalls


LIFT = "{skill: move_to, name: lift, params: {offset: [0.0, 0.0, 0.05], speed: 0.05}}"

FAILED_TASKS = {
    "hold: the fingers never close": (
        "hold", [LIFT, "{skill: hold, name: hold, params: {duration: 2.0}}"], "",
        "the box was never lifted off its stand (grip 0.00 N)"),
    "hold: the box slides beyond the tree's tolerance": (
        "hold", ["{skill: gentle_grasp, name: grasp, params: {squeeze: 0.001}}", LIFT,
                 "{skill: hold, name: hold, params: {duration: 8.0}}"], "{max_slip_mm: 0.01}",
        "mm in the grip > 0.01 mm"),
    "followme: the tree lets go before the person has led the block": (
        "followme", ["{skill: gentle_grasp, name: grasp, params: {squeeze: 0.002}}"], "",
        "into the person's 4 s lead"),
    "handover: the robot never takes the bottle": (
        "handover", ["{skill: move_to, name: carry, params: {offset: [0.1, 0.0, 0.0], speed: 0.1}}"], "",
        "the robot never took the bottle: the person was still offering it"),
    "inhand: the turn falls short of the tree's target": (
        "inhand", ["{skill: gentle_grasp, name: grasp}", LIFT,
                   "{skill: in_hand_man, name: pivot, params: {target: 20.0}}"], "{turn_deg: 60.0}",
        "deg in the hand, not 60 +- 10 deg"),
    "armrot: the stick is lifted but never balanced": (
        "armrot", ["{skill: gentle_grasp, name: grasp, params: {squeeze: 0.008, force: 60.0}}", LIFT], "",
        "deg from hanging > 10 deg"),
    "stir: the stick never dips into a bowl": (
        "stir", ["{skill: gentle_grasp, name: grasp, params: {squeeze: 0.008, force: 60.0}}",
                 f"{{skill: move_to, name: over, params: {{pose: {OVER_BOWL}, speed: 0.2}}}}"], "",
        "the stick dipped 0 times into a bowl < 1"),
    "stir: the stick dips but never stirs": (
        "stir", ["{skill: gentle_grasp, name: grasp, params: {squeeze: 0.008, force: 60.0}}",
                 f"{{skill: move_to, name: over, params: {{pose: {OVER_BOWL}, speed: 0.2}}}}",
                 "{skill: descend_until_contact, name: surface, params: {speed: 0.02, eps: 0.3}}",
                 "{skill: move_to, name: dip, params: {offset: [0.0, 0.0, -0.02], speed: 0.02}}"], "",
        "the stick stirred a substance for 0.0 s < 1 s"),
}


@pytest.mark.parametrize("case", list(FAILED_TASKS))
def test_a_tree_that_does_not_do_the_task_ends_task_failed_naming_the_shortfall(tmp_path, case):
    scene, children, tolerances, shortfall = FAILED_TASKS[case]
    _failed(_run(tmp_path, scene, children, tolerances), shortfall)


def test_a_press_replaced_by_success_fails_the_trees_force_target(tmp_path):
    """Before: SUCCESS with the scale at 2.67 N for a 5 N press."""
    summary = run_tree(str(TREES / "press_with_force.yaml"),
                       RunOptions(runs_dir=None, quiet=True, plots=False, substitutions=(parse_rule("press_demo/press=success"),)))
    _failed(summary, "the scale never read 5 N +- 1 N for 0.25 s (peak ")
    assert summary.truth.tolerances["press_force_N"] == 5.0


def test_a_press_tree_without_a_target_says_the_force_was_not_judged(tmp_path):
    summary = _run(tmp_path, "press", ["{skill: gentle_grasp, name: grasp, params: {squeeze: 0.002}}",
                                       "{skill: descend_until_contact, name: touch, params: {speed: 0.005, eps: 0.3}}"])
    assert summary.status == "SUCCESS" and summary.truth.shortfalls == []
    assert summary.truth.unjudged == [("press_force_N (the force the scale must feel, N): not judged, the tree sets "
                                       "no target (cell.tolerances.press_force_N)")]


def test_a_hold_demo_judges_grip_and_slip_and_reports_the_tolerances(tmp_path):
    summary = run_tree(str(TREES / "hold.yaml"), RunOptions(runs_dir=None, quiet=True, plots=False))
    assert summary.status == "SUCCESS"
    assert summary.truth.tolerances == {"min_grip_N": 1.0, "max_slip_mm": 5.0}


@pytest.mark.slow
def test_a_resume_judges_the_element_a_person_marked_placed(tmp_path):
    """Before: the marked element kept the earlier session's 'placing' entry, was never judged,
    and the run said SUCCESS with '1 of 2' placed."""
    first = run_tree(str(TREES / "assembly.yaml"), RunOptions(runs_dir=tmp_path, estop_at=124.5, quiet=True, plots=False))
    assert first.elements["E1"]["status"] == "placing"
    second = run_tree(str(TREES / "assembly.yaml"), RunOptions(runs_dir=tmp_path, resume="latest", marks={"E1": "placed"},
                                                                quiet=True, plots=False))
    e1 = second.elements["E1"]
    assert e1["status"] == "placed" and e1["plate"] == "P1" and "regret" in e1  # judged where it stands
    assert all(e["status"] == "placed" for e in second.elements.values())
    assert second.truth.unjudged == []
    assert second.status == ("TASK_FAILED" if e1["regret"] > 0.01 else "SUCCESS")


def test_a_press_that_goes_on_past_its_target_ends_task_failed(tmp_path):
    """The scale reads 5 N on the way, but the press ends beyond it with the stick still pressed (as
    press_with_force did on randomised seed 2 before it measured the skin: 7 N beyond). Before this
    rule: SUCCESS (the bench flagged it)."""
    summary = _run(tmp_path, "press", ["{skill: gentle_grasp, name: grasp, params: {squeeze: 0.002}}",
                                       "{skill: descend_until_contact, name: touch, params: {speed: 0.005, eps: 0.3}}",
                                       "{skill: move_to, name: push, params: {offset: [0.0, 0.0, -0.002], speed: 0.001}}"],
                   "{press_force_N: 5.0}")
    _failed(summary, "the press ends with the scale at ")
