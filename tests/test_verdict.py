"""The verdict of simulated runs: a tree that says SUCCESS while the scene's truth shows the task
was not done ends TASK_FAILED (exit code 5) with each shortfall and the tolerances it was judged
by; tolerances come from the scene and may be set in the tree (`cell.tolerances`), checked with
file and line; `fvtree run --scene` replaces the tree's scene."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from assembly.cli import main
from assembly.outcome.verdict import TASK_FAILED, Verdict
from assembly.run.options import RunOptions
from assembly.run.session import run_tree
from drivers.sim.scenes.assembly import AssemblyScene

TREES = Path(__file__).resolve().parents[1] / "trees"


def _object_track(tmp_path: Path, cell: str) -> Path:
    """The object_track demo with another `cell:` line."""
    text = (TREES / "object_track.yaml").read_text().replace("cell: {tick_hz: 30, scene: followme}", cell)
    path = tmp_path / "track.yaml"
    path.write_text(text)
    return path


def test_a_successful_run_reports_the_tolerances_it_was_judged_by(tmp_path):
    summary = run_tree(str(TREES / "object_track.yaml"), RunOptions(runs_dir=tmp_path, quiet=True, plots=False))
    assert summary.status == "SUCCESS"
    assert summary.truth == Verdict({"max_final_error_mm": 20.0, "max_rms_error_mm": 25.0}, [])
    written = json.loads((Path(summary.run_dir) / "summary.json").read_text())
    assert written["truth"]["tolerances"] == {"max_final_error_mm": 20.0, "max_rms_error_mm": 25.0}


def test_success_that_the_truth_denies_is_task_failed_with_exit_code_5(tmp_path, capsys):
    tree = _object_track(tmp_path, "cell: {tick_hz: 30, scene: followme, tolerances: {max_final_error_mm: 0.5}}")
    assert main(["run", str(tree), "--runs-dir", str(tmp_path / "runs"), "--no-plots"]) == 5
    out = capsys.readouterr().out
    assert out.startswith("TASK_FAILED: the tree succeeded but the scene's truth shows the task was not done")
    assert "not done: the tool ended" in out and "> 0.5 mm" in out
    assert "judged by the scene's truth with max_final_error_mm 0.5" in out
    summary = json.loads(next((tmp_path / "runs").glob("*/summary.json")).read_text())
    assert summary["status"] == TASK_FAILED and summary["tree_status"] == "SUCCESS"
    assert len(summary["truth"]["shortfalls"]) == 1


def test_a_failed_tree_keeps_its_own_status_and_lists_what_the_truth_shows(tmp_path):
    tree = tmp_path / "drop.yaml"
    tree.write_text("""version: 1
name: drop_box
cell: {tick_hz: 30, scene: hold}
root:
  sequence: drop_box
  memory: true
  children:
    - {skill: gentle_grasp, name: grasp, params: {squeeze: 0.001}}
    - {skill: move_to, name: lift, params: {offset: [0.0, 0.0, 0.05], speed: 0.05}}
    - {skill: release, name: let_go}
""")
    summary = run_tree(str(tree), RunOptions(runs_dir=tmp_path, quiet=True, plots=False))
    assert summary.status == "FAILURE" and summary.tree_status is None
    assert summary.truth.shortfalls == ["the box was dropped"]


@pytest.mark.parametrize("setting, message", [
    ("{max_regret: -1}", "track.yaml:5: cell.tolerances.max_regret: must be at least 0, got -1"),
    ("{max_regret: 0.1}", ("track.yaml:5: cell.tolerances.max_regret: scene 'followme' has no tolerance "
                           "'max_regret' (scene 'followme' has: max_final_error_mm, max_rms_error_mm)")),
    ("{max_final_eror_mm: 3}", "did you mean 'max_final_error_mm'?"),
])
def test_bad_tolerances_are_refused_with_file_line_and_field(tmp_path, capsys, setting, message):
    tree = _object_track(tmp_path, f"cell: {{tick_hz: 30, scene: followme, tolerances: {setting}}}")
    assert main(["run", str(tree), "--runs-dir", str(tmp_path / "runs")]) == 2
    assert message in capsys.readouterr().err


class _Beam:
    """A plate whose true best position is 0.5 m carrying 10 N there, 9 N at 0.45 m."""

    span = 1.0

    def max_load(self, clearance):
        return 0.5, 10.0

    def carried_force(self, a, clearance):
        return 10.0 - 20.0 * np.abs(np.asarray(a) - 0.5)

    def weight(self):
        return 140.0


def test_assembly_truth_names_each_element_placed_beyond_the_regret_tolerance():
    class Placed:
        def __init__(self, eid, state):
            self.id, self.state = eid, state

        def ends(self):
            return None, np.array([0.45, 0.0, 0.3])

    class Plate:
        id, origin, beam = "P1", np.array([0.0, 0.0, 0.31]), _Beam()

        def position_along(self, point):
            return float(point[0])

    scene = AssemblyScene.__new__(AssemblyScene)
    scene.elements = {"E1": Placed("E1", "standing"), "E2": Placed("E2", "dropped")}
    scene.plate_above = lambda top: Plate()
    scene.plates, scene.plate_pushes = {"P1": Plate()}, {}
    assert scene.shortfalls({"max_regret": 0.2}) == ["E2 fell when it was released"]
    assert scene.shortfalls({"max_regret": 0.05}) == [
        "E2 fell when it was released", "E1 props P1 -50 mm from the true maximum, regret 10 % > 5 %"]


def test_scene_option_replaces_the_trees_scene(tmp_path, capsys):
    tree = str(TREES / "hold.yaml")
    assert main(["run", tree, "--scene", "hol", "--runs-dir", str(tmp_path)]) == 2
    assert "--scene hol: no simulated scene 'hol' (did you mean 'hold'?)" in capsys.readouterr().err
    summary = run_tree(tree, RunOptions(scene="inhand", runs_dir=tmp_path, quiet=True, plots=False))
    assert "turned in the hand (deg)" in summary.metrics
