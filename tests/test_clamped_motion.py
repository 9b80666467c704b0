"""A clamped motion is a failure: a move whose target the safety layer pulls into the workspace box
fails its skill naming the requested and the reachable position (before: SUCCESS "to [2.5, -1.8,
0.3]" with only `safety_clamps: 1` in the summary), and `reach_errors` refuses a tree whose constant
poses or offsets leave the cell's box before it runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from assembly.errors import TreeError, TreeErrors
from assembly.language.reach import reach_errors
from assembly.language.reader import load_tree
from assembly.run.options import RunOptions
from assembly.run.session import run_tree
from drivers.clock import SimClock
from drivers.safety import SafeArm, SafetyLimits
from drivers.sim.devices.arm import KinematicArm

TREES = Path(__file__).resolve().parents[1] / "trees"


def _tree(tmp_path: Path, *children: str) -> Path:
    body = "\n".join(f"    - {child}" for child in children)
    path = tmp_path / "moves.yaml"
    path.write_text(f"version: 1\nname: moves\ncell: {{tick_hz: 30, scene: hold}}\nroot:\n  sequence: moves\n"
                    f"  memory: true\n  children:\n{body}\n")
    return path


FAR = "{skill: move_to, name: away, params: {pose: [2.5, -1.8, 0.3, 3.141593, 0.0, 0.0]}}"
LIFT_IN_MM = "{skill: move_to, name: lift, params: {offset: [0.0, 0.0, 50]}}"


@pytest.mark.parametrize(("node", "requested", "reachable"), [
    (FAR, "[2.5, -1.8, 0.3]", "[0.9, -0.9, 0.3]"),
    (LIFT_IN_MM, "[0.0, 0.0, 50.5]", "[0.0, 0.0, 0.9]"),
])
def test_a_move_the_safety_layer_clamps_fails_naming_requested_and_reachable(tmp_path, node, requested, reachable):
    """The run-time layer under the check below: `fvtree run` refuses such a tree before it builds the
    cell (reach_errors), so the tree is read here without the cell's box, as a pose computed at run
    time would reach the safety layer."""
    path = _tree(tmp_path, node)
    with pytest.raises(TreeErrors, match="outside the cell's workspace|cannot stay inside"):
        run_tree(str(path), RunOptions(runs_dir=None, quiet=True, plots=False))
    summary = run_tree(load_tree(path), RunOptions(runs_dir=None, quiet=True, plots=False))
    assert summary.status == "FAILURE"
    assert summary.message == (f"the requested position {requested} is outside the cell's workspace; the nearest "
                               f"reachable is {reachable} (the arm was not moved there)")
    assert summary.safety_clamps == 1


def test_the_safe_arm_tells_the_last_move_it_clamped_until_the_next_move():
    clock = SimClock(0.01)
    arm = SafeArm(KinematicArm(clock, np.array([0.0, 0.0, 0.5, np.pi, 0.0, 0.0])), SafetyLimits(), clock)
    arm.move_linear(np.array([2.0, 0.0, 0.5, np.pi, 0.0, 0.0]), 0.1)
    requested, reachable = arm.clamped_target
    assert requested.tolist() == [2.0, 0.0, 0.5] and reachable.tolist() == [1.0, 0.0, 0.5]
    arm.move_linear(np.array([0.1, 0.0, 0.5, np.pi, 0.0, 0.0]), 0.1)
    assert arm.clamped_target is None


def test_constant_poses_and_offsets_outside_the_cells_box_are_refused_at_their_node(tmp_path):
    doc = load_tree(_tree(tmp_path, FAR, LIFT_IN_MM, "{skill: move_to, name: fine, params: {offset: [0.0, 0.0, 0.05]}}"))
    errors = reach_errors(doc.root, "sim")
    assert all(isinstance(e, TreeError) for e in errors)
    assert [str(e).split(" (the workspace of")[0] for e in errors] == [
        (f"{doc.path}:8: moves/away: param 'pose' = [2.5, -1.8, 0.3] is outside the cell's workspace "
        "(x 2.5 not in [-0.9, 0.9], y -1.8 not in [-0.9, 0.9])"),
        (f"{doc.path}:9: moves/lift: param 'offset' = [0.0, 0.0, 50.0] cannot stay inside the cell's workspace "
        "from anywhere in it (z 50 m > the box's 0.9 m)")]
    assert errors[0].hint.endswith("poses and offsets are in metres")


@pytest.mark.parametrize("tree", sorted(p.name for p in TREES.glob("*.yaml")))
def test_every_shipped_tree_stays_inside_the_simulated_cells_box(tree):
    assert reach_errors(load_tree(TREES / tree).root, "sim") == []
