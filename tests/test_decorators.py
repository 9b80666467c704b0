"""Decorators and composites of the tree language, ticked by hand on the mocked cell."""

from __future__ import annotations

import json

from assembly.cli import main
from assembly.testing import TreeHarness

LONG_MOVE = "{skill: move_to, name: go, params: {offset: [0.3, 0, 0], speed: 0.1}}"  # 3 s of motion


def harness(root: str) -> TreeHarness:
    return TreeHarness.from_text(f"version: 1\nname: t\ncell: {{tick_hz: 10}}\nroot:\n{root}")


def test_timeout_runs_on_the_cell_clock_and_halts_the_child():
    h = harness(f"  timeout: limit\n  seconds: 1.0\n  child: {LONG_MOVE}\n")
    h.tick(10)  # t = 0.0 .. 0.9 s
    h.assert_status({"limit": "RUNNING", "limit/go": "RUNNING"})
    h.tick()  # t = 1.0 s
    h.assert_status({"limit": "FAILURE", "limit/go": "INVALID"})
    assert "timed out after 1.0 s" in h.feedback("limit")
    assert h.arm.commands[-1].name == "stop" and h.arm.commands[-1].t == 1.0


def test_guard_rechecks_every_tick_and_halts_the_child():
    h = harness("  guard: while_clear\n  while: {key: /task/estop, op: eq, value: false}\n"
                f"  child: {LONG_MOVE}\n")
    h.tick(3)
    h.assert_status({"while_clear": "RUNNING", "while_clear/go": "RUNNING"})
    h.cell.estop = True  # published as /task/estop by the perception stage next tick
    h.tick()
    h.assert_status({"while_clear": "FAILURE", "while_clear/go": "INVALID"})
    assert h.arm.commands[-1].name == "stop"
    # the failure says why: the key, the value it read and the comparison that did not hold
    assert h.feedback("while_clear") == "guard condition failed: /task/estop = True, not eq False"


def test_a_failed_condition_says_which_key_its_value_and_the_comparison():
    h = harness("  sequence: s\n  memory: true\n  children:\n"
                "    - {condition: wide, key: /gripper/width, op: gt, value: 0.5}\n")
    h.tick()
    h.assert_status({"s/wide": "FAILURE"})
    assert h.feedback("s/wide").startswith("/gripper/width = ")
    assert h.feedback("s/wide").endswith(", not gt 0.5")
    h = harness("  sequence: s\n  memory: true\n  children:\n"
                "    - {condition: pushed, key: \"/fv/left.force[1]\", op: lt, value: -1.0}\n")
    h.tick()
    assert h.feedback("s/pushed") == "/fv/left.force[1] = 0.0, not lt -1.0"


def test_status_map_and_inverter():
    failing = "{condition: never, key: /gripper/width, op: lt, value: 0.0}"
    h = harness(f"  status_map: ok\n  map: {{failure: success}}\n  child: {failing}\n")
    h.tick()
    h.assert_status({"ok": "SUCCESS", "ok/never": "FAILURE"})
    h = harness(f"  inverter: not\n  child: {failing}\n")
    h.tick()
    h.assert_status({"not": "SUCCESS"})


def test_retry_fails_after_its_attempts():
    h = harness("  retry: again\n  attempts: 3\n  child: {condition: never, key: /gripper/width, op: lt, value: 0.0}\n")
    statuses = [h.tick().name for _ in range(3)]
    assert statuses == ["RUNNING", "RUNNING", "FAILURE"]


def test_repeat_succeeds_after_n_successes():
    h = harness("  repeat: thrice\n  times: 3\n  child: {condition: open, key: /gripper/width, op: gt, value: 0.05}\n")
    statuses = [h.tick().name for _ in range(3)]
    assert statuses == ["RUNNING", "RUNNING", "SUCCESS"]


def test_parallel_policies():
    cond = "{condition: open, key: /gripper/width, op: gt, value: 0.05}"
    h = harness(f"  parallel: both\n  policy: one\n  children:\n    - {LONG_MOVE}\n    - {cond}\n")
    h.tick()
    h.assert_status({"both": "SUCCESS", "both/go": "INVALID"})
    h = harness(f"  parallel: both\n  policy: all\n  children:\n    - {LONG_MOVE}\n    - {cond}\n")
    h.tick()
    h.assert_status({"both": "RUNNING", "both/open": "SUCCESS"})
    h = harness(f"  parallel: both\n  policy: selected\n  selected: [open]\n  children:\n    - {LONG_MOVE}\n    - {cond}\n")
    h.tick()
    h.assert_status({"both": "SUCCESS"})


def test_memoryless_selector_gives_the_estop_guard_priority():
    h = harness(f"  selector: main\n  memory: false\n  children:\n    - {{skill: estop_guard, name: estop}}\n"
                f"    - {LONG_MOVE}\n")
    h.tick(2)
    h.assert_status({"main/estop": "FAILURE", "main/go": "RUNNING"})
    h.cell.estop = True
    h.tick()
    h.assert_status({"main/estop": "RUNNING", "main/go": "INVALID"})
    assert [c.name for c in h.arm.commands[-2:]] == ["stop", "stop"]  # terminate, then the guard


def test_conditions_compare_nested_values():
    h = harness("  sequence: s\n  memory: false\n  children:\n"
                "    - {condition: high, key: '/robot/pose[2]', op: ge, value: 0.5}\n"
                "    - {condition: calm, key: /fv/left.slip, op: le, value: 0.01}\n"
                "    - {condition: has, key: /robot/fault, op: eq, value: null}\n")
    h.tick()
    h.assert_status({"s": "SUCCESS"})


def test_a_failed_guards_reason_reaches_the_run_summary_and_the_transition_log(tmp_path):
    tree = tmp_path / "t.yaml"
    tree.write_text("version: 1\nname: t\ncell: {scene: hold}\nroot:\n  guard: pressed\n"
                    "  while: {key: \"/fv/left.force[1]\", op: gt, value: 5.0}\n"
                    f"  child: {LONG_MOVE}\n")
    assert main(["run", str(tree), "--runs-dir", str(tmp_path / "runs"), "--no-record", "--no-plots"]) != 0
    (run,) = (tmp_path / "runs").iterdir()
    summary = json.loads((run / "summary.json").read_text())
    assert summary["where"] == "pressed"
    assert summary["message"].startswith("guard condition failed: /fv/left.force[1] = ")
    assert summary["message"].endswith(", not gt 5.0")
    transitions = [json.loads(line) for line in (run / "transitions.jsonl").read_text().splitlines()]
    assert any(t["node"] == "pressed" and t["to"] == "FAILURE" and t["feedback"] == summary["message"]
               for t in transitions)
