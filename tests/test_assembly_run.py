"""The flagship assembly on the simulated cell: result, as-built data, logs, e-stop, resume (of
exactly this tree, unchanged, never re-picking an element left being released), Ctrl-C and
crash-safe writes."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from assembly.cli import main
from assembly.design.model import DesignModel
from assembly.errors import TreeError
from assembly.language.build import build
from assembly.language.reader import load_tree
from assembly.run.loop import Runner
from assembly.run.options import RunOptions
from assembly.run.session import run_tree
from drivers.cell_builders import load_cell
from fvfiles.json_files import atomic_write_json

TREES = Path(__file__).resolve().parents[1] / "trees"
ASSEMBLY = str(TREES / "assembly.yaml")


def lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    return run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path_factory.mktemp("runs"), quiet=True))


def test_assembly_places_every_element_at_its_maximum_load(full_run):
    assert full_run.status == "SUCCESS"
    for eid, e in full_run.elements.items():
        assert e["status"] == "placed", eid
        assert e["regret"] < 0.01, f"{eid}: force regret {e['regret']:.2%}"
        assert abs(e["position"] - e["true_best_position"]) < 0.03


def test_run_directory_holds_the_as_built_model_and_logs(full_run):
    run_dir = Path(full_run.run_dir)
    asbuilt = DesignModel.load(run_dir / "asbuilt.json")
    for eid in ("E1", "E2"):
        node = asbuilt.graph.nodes[eid]
        assert node["status"] == "placed" and len(node["asbuilt_pose"]) == 6 and node["measured_load"] > 0
    events = [e["event"] for e in lines(run_dir / "events.jsonl")]
    assert events == ["start", "placing", "placed", "retreated", "placing", "placed", "retreated", "end"]
    assert json.loads((run_dir / "run.json").read_text())["tree"] == "architectural_assembly"
    transitions = lines(run_dir / "transitions.jsonl")
    assert transitions[0]["tick"] == 0 and {"t", "node", "from", "to", "feedback"} <= set(transitions[0])
    assert transitions[-1]["node"] == "main" and transitions[-1]["to"] == "SUCCESS"
    assert (run_dir / "load_profiles.png").stat().st_size > 10_000
    assert json.loads((run_dir / "summary.json").read_text())["status"] == "SUCCESS"


def test_simulated_runs_are_deterministic(full_run, tmp_path):
    again = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, quiet=True, plots=False))
    assert again.ticks == full_run.ticks
    for eid in ("E1", "E2"):
        assert again.elements[eid]["position"] == full_run.elements[eid]["position"]


def test_estop_halts_then_resume_skips_placed_elements(tmp_path):
    first = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, estop_at=170.0, quiet=True, plots=False))
    assert first.status == "ESTOP"
    assert "/build/prop/" in first.where
    assert first.elements["E1"]["status"] == "placed"
    assert first.elements["E2"]["status"] == "planned"
    run_dir = Path(first.run_dir)
    assert lines(run_dir / "events.jsonl")[-2]["event"] == "halted"

    second = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, resume="latest", quiet=True, plots=False))
    assert second.status == "SUCCESS" and second.run_dir == first.run_dir
    placed = [e["element"] for e in lines(run_dir / "events.jsonl") if e["event"] == "placed"]
    assert placed == ["E1", "E2"]  # E1 was not built twice
    assert second.elements["E2"]["regret"] < 0.01
    assert second.elements["E1"] == first.elements["E1"]  # judged when placed, not again

    third = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, resume="latest", quiet=True, plots=False))
    assert third.nothing_to_do and third.status == "SUCCESS"
    assert main(["run", ASSEMBLY, "--runs-dir", str(tmp_path), "--resume"]) == 0


def test_a_resume_never_picks_again_an_element_left_being_released(tmp_path, capsys):
    first = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, estop_at=124.5, quiet=True, plots=False))
    assert first.status == "ESTOP" and first.where.endswith("/prop/place")
    assert first.elements["E1"]["status"] == "placing"
    assert main(["run", ASSEMBLY, "--runs-dir", str(tmp_path), "--resume"]) == 2
    err = capsys.readouterr().err
    assert "asbuilt.json: element E1 was being released on plate P1 at [" in err
    assert "--mark E1=placed" in err and "--mark E1=planned" in err

    second = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, resume="latest", marks={"E1": "placed"}, quiet=True, plots=False))
    assert second.status == "SUCCESS"
    events = lines(Path(first.run_dir) / "events.jsonl")
    assert [e["element"] for e in events if e["event"] == "placing"] == ["E1", "E2"]
    assert [(e["element"], e["status"]) for e in events if e["event"] == "marked"] == [("E1", "placed")]


def tree_copy(tmp_path: Path, name: str) -> Path:
    """The assembly tree under another name, next to copies of its subtrees and design."""
    for sub in ("subtrees", "design"):
        if not (tmp_path / sub).exists():
            shutil.copytree(TREES / sub, tmp_path / sub)
    path = tmp_path / f"{name}.yaml"
    path.write_text((TREES / "assembly.yaml").read_text().replace("name: architectural_assembly", f"name: {name}"))
    return path


def test_resume_takes_the_run_of_exactly_this_tree_unchanged(tmp_path):
    runs = tmp_path / "runs"
    asm, asm_b = tree_copy(tmp_path, "asm"), tree_copy(tmp_path, "asm_b")
    mine = run_tree(str(asm), RunOptions(runs_dir=runs, estop_at=5.0, quiet=True, plots=False))
    run_tree(str(asm_b), RunOptions(runs_dir=runs, estop_at=5.0, quiet=True, plots=False))  # later, and a prefix match
    resumed = run_tree(str(asm), RunOptions(runs_dir=runs, resume="latest", estop_at=10.0, quiet=True, plots=False))
    assert resumed.run_dir == mine.run_dir

    asm.write_text(asm.read_text().replace("scan_step: 0.002", "scan_step: 0.003"))
    with pytest.raises(TreeError, match="the tree .* changed since this run started"):
        run_tree(str(asm), RunOptions(runs_dir=runs, resume="latest", quiet=True, plots=False))
    with pytest.raises(TreeError, match="no earlier run of 'asm_c'"):
        run_tree(str(tree_copy(tmp_path, "asm_c")), RunOptions(runs_dir=runs, resume="latest", quiet=True, plots=False))


def test_a_tree_name_cannot_place_its_run_directory_outside_the_runs_directory(tmp_path):
    tree = tmp_path / "escape.yaml"
    tree.write_text('version: 1\nname: "../../x"\nroot: {skill: move_to, name: go, params: {offset: [0.01, 0, 0]}}\n')
    summary = run_tree(str(tree), RunOptions(runs_dir=tmp_path / "runs", quiet=True, plots=False))
    run_dir = Path(summary.run_dir)
    assert summary.status == "SUCCESS" and run_dir.parent == tmp_path / "runs"
    assert run_dir.name.endswith("-x") and not (tmp_path / "x").exists()


def test_ctrl_c_halts_every_running_skill_and_stops_the_arm(tmp_path):
    doc = load_tree(ASSEMBLY)
    cell = load_cell("sim", doc.tick_hz, doc.scene, doc.design.scene_args())

    def interrupt_at_tick_400():
        if runner.ticks == 400:
            raise KeyboardInterrupt
        return cell.sense()

    runner = Runner(build(doc), cell, tmp_path, sense=interrupt_at_tick_400)
    runner.setup()
    result = runner.run()
    assert result.status == "HALTED" and result.where.endswith("/scan")
    assert not cell.arm.is_moving() and not cell.gripper.is_moving()
    assert all(node.status.name == "INVALID" for node in runner.tree.nodes.values())
    assert lines(tmp_path / "transitions.jsonl")[-1]["to"] == "INVALID"


def test_interrupted_write_keeps_the_previous_as_built_model(tmp_path, monkeypatch):
    path = tmp_path / "asbuilt.json"
    atomic_write_json(path, {"nodes": [1]})

    def crash(*args, **kwargs):
        raise KeyboardInterrupt  # the process is stopped in the middle of writing

    monkeypatch.setattr(json, "dump", crash)
    with pytest.raises(KeyboardInterrupt):
        atomic_write_json(path, {"nodes": [1, 2]})
    assert json.loads(path.read_text()) == {"nodes": [1]}
    assert [p.name for p in tmp_path.iterdir()] == ["asbuilt.json"]  # no temp file left


def test_build_order_follows_the_precedence_edges():
    data = json.loads((TREES / "design" / "two_bays.json").read_text())
    assert DesignModel(nx.node_link_graph(data, edges="edges")).build_order() == ["E1", "E2"]
    data["edges"] = [{"source": "E2", "target": "E1"}]
    assert DesignModel(nx.node_link_graph(data, edges="edges")).build_order() == ["E2", "E1"]


def test_bad_cell_file_names_file_line_and_field(tmp_path, capsys):
    cell = tmp_path / "cell.yaml"
    cell.write_text("kind: sim\nsafety:\n  max_sped: 0.2\n")
    assert main(["run", ASSEMBLY, "--cell", str(cell), "--runs-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"{cell}:2: safety:" in err and "max_sped" in err and "Traceback" not in err


def test_safety_layer_clamps_a_target_outside_the_workspace_and_the_move_fails():
    doc = load_tree(text="version: 1\nname: t\nroot: {skill: move_to, name: far, params: {pose: [2.0, 0, 0.5, 3.14159, 0, 0]}}\n",
                    name="far.yaml")
    cell = load_cell("sim", 30, "assembly", {})
    runner = Runner(build(doc), cell, max_time=30)
    runner.setup()
    result = runner.run()
    assert result.status == "FAILURE"  # a clamped move is not where the tree asked: the skill fails
    assert "the requested position [2.0, 0.0, 0.5] is outside the cell's workspace; the nearest reachable is " \
           "[0.9, 0.0, 0.5]" in result.message
    assert cell.arm.clamped == 1 and cell.arm.pose()[0] < 0.9
    assert np.all(cell.arm.pose()[:3] <= cell.arm.limits.workspace_max)
