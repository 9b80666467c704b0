"""The stop policy on the mocked cell: the ESTOP file, a scheduled e-stop, the cell-time limit,
the node an e-stop names, and what a halt stops."""

from __future__ import annotations

import json

from assembly.language.build import build
from assembly.language.reader import load_tree
from assembly.run.loop import Runner
from assembly.testing import mock_cell

MOVE = "{{skill: move_to, name: {name}, params: {{offset: [{dx}, 0, 0], speed: 0.1}}}}"  # 1 s per 0.1 m
TWO_MOVES = ("  sequence: main\n  memory: true\n  children:\n    - " + MOVE.format(name="go", dx=0.3) + "\n    - "
             + MOVE.format(name="back", dx=-0.3) + "\n")


def runner(root: str, run_dir=None, **kwargs) -> Runner:
    doc = load_tree(text=f"version: 1\nname: t\ncell: {{tick_hz: 10}}\nroot:\n{root}", name="t.yaml")
    the_runner = Runner(build(doc), mock_cell(doc.tick_hz), run_dir, **kwargs)
    the_runner.setup()
    return the_runner


def test_an_estop_file_stops_the_run_at_the_next_tick(tmp_path):
    r = runner(TWO_MOVES, tmp_path)
    for _ in range(5):  # not a multiple of any polling interval
        r.tick()
    (tmp_path / "ESTOP").touch()
    result = r.run()
    assert result.status == "ESTOP" and result.ticks == 6
    assert result.where == "main/go" and result.message == "e-stop requested during main/go"
    assert r.cell.estop


def test_a_scheduled_estop_stops_at_its_cell_time():
    result = runner(TWO_MOVES, estop_at=1.5).run()
    assert result.status == "ESTOP" and result.ticks == 16  # ticks at t = 0.0 .. 1.5 s
    assert result.where == "main/go"


def test_an_estop_during_the_first_node_names_it():
    result = runner(TWO_MOVES, estop_at=0.0).run()
    assert result.status == "ESTOP" and result.ticks == 1
    assert result.where == "main/go" and result.message.endswith("during main/go")


def test_an_estop_names_the_node_running_when_it_came():
    result = runner(TWO_MOVES, estop_at=4.0).run()  # the first move takes 3 s
    assert result.status == "ESTOP" and result.where == "main/back"


def test_the_cell_time_limit_stops_the_run():
    result = runner(TWO_MOVES, max_time=0.5).run()
    assert result.status == "TIMEOUT" and result.message == "no result within 0.5 s of cell time (during main/go)"
    assert 0.5 < result.sim_time < 0.65 and result.where == "main/go"


def test_a_halted_run_stops_the_tree_the_arm_and_the_gripper(tmp_path):
    r = runner(TWO_MOVES, tmp_path, estop_at=0.5)
    arm, gripper = r.cell.arm, r.cell.gripper
    for _ in range(3):
        r.tick()
    gripper.move(0.0, 0.01)  # as a skill opening or closing the fingers would
    assert arm.is_moving() and gripper.is_moving()
    result = r.run()
    assert result.status == "ESTOP"
    assert arm.commands[-1].name == "stop" and gripper.commands[-1].name == "stop"
    assert not arm.is_moving() and not gripper.is_moving()
    assert all(node.status.name == "INVALID" for node in r.tree.nodes.values())
    last = [json.loads(line) for line in (tmp_path / "transitions.jsonl").read_text().splitlines()][-1]
    assert last["to"] == "INVALID" and last["tick"] == result.ticks
