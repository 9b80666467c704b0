"""The cell supervisor on the simulated cell: each fault latches a stop of arm and gripper within
its bound in cell time, fails the run with status FAULT and names the cause and the node; frozen
perception is noticed before the arm presses harder than a normal contact."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from assembly.cli import main
from assembly.language.build import build
from assembly.language.reader import load_tree
from assembly.run.loop import Runner
from assembly.run.supervisor import Supervision
from assembly.testing import mock_cell, touch
from drivers.cell_builders import load_cell
from drivers.cell_file import CellFileError

ASSEMBLY = str(Path(__file__).resolve().parents[1] / "trees" / "assembly.yaml")
MOVES = """version: 1
name: moves
cell: {tick_hz: 30}
root:
  sequence: main
  memory: true
  children:
    - {skill: move_to, name: go, params: {offset: [0.3, 0, 0], speed: 0.1}}
    - {skill: descend_until_contact, name: feel, params: {speed: 0.01}}
"""


class Recorder:
    """A sense that records, per tick, the cell time, the tip, the TCP force and whether the arm
    moves, and that can freeze (keep returning the states of one tick) or run a hook."""

    def __init__(self, cell, hook=None):
        self.cell, self.hook = cell, hook
        self.rows: list[tuple[float, str, float, bool]] = []
        self.frozen: dict | None = None
        self.runner: Runner | None = None

    def __call__(self) -> dict:
        states = self.frozen or self.cell.sense()
        if self.hook is not None:
            self.hook(self)
        self.rows.append((self.cell.clock.now(), self.runner.tip.path,
                          # the force the scene puts on the arm, not the TCP sensor's offset, noisy reading
                          float(np.linalg.norm(self.cell.world.arm.tcp_wrench()[:3])), self.cell.arm.is_moving()))
        return states

    def freeze(self) -> None:
        self.frozen = self.cell.sense()


def supervised_assembly(hook=None, settings: Supervision | None = None, max_time: float = 400.0):
    doc = load_tree(ASSEMBLY)
    cell = load_cell("sim", doc.tick_hz, doc.scene, doc.design.scene_args())
    recorder = Recorder(cell, hook)
    runner = Runner(build(doc), cell, sense=recorder, supervision=settings or Supervision(), max_time=max_time)
    recorder.runner = runner
    runner.setup()
    return runner, recorder, runner.run()


def assert_cell_stopped(runner: Runner) -> None:
    """Arm and gripper are still, latched, and stay still while the cell keeps stepping."""
    cell = runner.cell
    pose, width = cell.arm.pose().copy(), cell.gripper.width()
    for _ in range(30):
        cell.step()
    assert not cell.arm.is_moving() and not cell.gripper.is_moving()
    assert np.allclose(cell.arm.pose(), pose) and cell.gripper.width() == width
    assert cell.arm.fault() and cell.gripper.fault()
    assert all(node.status.name == "INVALID" for node in runner.tree.nodes.values())


def test_a_gripper_fault_while_carrying_stops_the_arm_within_a_tenth_of_a_second():
    injected = {}

    def overcurrent(rec):
        if "t" not in injected and rec.runner.tip.path.endswith("/approach"):
            rec.cell.gripper.inner.fault_text = "overcurrent"
            injected["t"] = rec.cell.clock.now()

    runner, recorder, result = supervised_assembly(overcurrent)
    assert result.status == "FAULT" and result.where.endswith("/build/prop/approach")
    assert result.message.startswith("gripper fault:") and "overcurrent" in result.message
    assert result.message.endswith("(during main/assemble/elements/build/prop/approach)")
    assert runner.supervisor.tripped_at - injected["t"] <= 0.1
    assert not any(moving for t, _, _, moving in recorder.rows if t > injected["t"] + 0.1)
    assert_cell_stopped(runner)


def test_frozen_perception_stops_the_arm_within_the_stale_limit_without_pressing_harder():
    """The stream freezes as the descent begins: the arm stops within the stale limit, before
    the element presses on the plate harder than it does when carried (its weight)."""
    def freeze(rec):
        if rec.frozen is None and rec.runner.tip.path.endswith("/descend"):
            rec.freeze()

    runner, recorder, result = supervised_assembly(freeze, max_time=90.0)
    assert result.status == "FAULT" and result.where.endswith("/descend_limit/descend")
    assert "perception on /fv/left is" in result.message and "s old (limit 0.2 s)" in result.message
    descending = [(t, f) for t, tip, f, _ in recorder.rows if tip.endswith("/descend")]
    frozen_at = descending[1][0]  # the first tick with no fresh state
    assert runner.supervisor.tripped_at - frozen_at <= 0.2 + 1e-9
    weight = descending[0][1]
    assert max(f for _, f in descending) <= weight + 1e-6
    assert_cell_stopped(runner)


def test_the_run_reports_how_close_it_came_to_each_limit():
    """The summary's margins: the worst perception age, arm data age and tick gap beside their
    limits; on the frozen stream the perception age reached its limit, the rest stayed at a tick."""
    def freeze(rec):
        if rec.frozen is None and rec.runner.tip.path.endswith("/descend"):
            rec.freeze()

    _, _, result = supervised_assembly(freeze, max_time=90.0)
    margins = result.margins
    assert margins["perception_age_s"]["limit"] == 0.2 and margins["perception_age_s"]["worst"] >= 0.2
    assert margins["arm_state_age_s"] == {"worst": 0.0, "limit": 0.1}  # the simulated arm's state is always new
    assert margins["tick_gap_s"]["worst"] == pytest.approx(1 / 30, abs=1e-3)


def test_an_arm_fault_stops_the_cell_and_names_the_node():
    def fault(rec):
        if rec.runner.ticks == 300:
            rec.cell.arm.inner.fault_text = "joint 3 overtemperature"

    runner, _, result = supervised_assembly(fault)
    assert result.status == "FAULT" and "arm fault" in result.message and "joint 3 overtemperature" in result.message
    assert result.where and result.message.endswith(f"(during {result.where})")
    assert_cell_stopped(runner)


def moves_runner(settings: Supervision | None = None, healthy=lambda tick: True, **cell_args):
    doc = load_tree(text=MOVES, name="moves.yaml")
    cell = mock_cell(doc.tick_hz, **cell_args)
    runner = Runner(build(doc), cell, supervision=settings or Supervision(), max_time=60.0,
                    sense=lambda: {f: touch(f, stamp=cell.clock.now(), healthy=healthy(runner.ticks))
                                   for f in ("left", "right")})
    runner.setup()
    return runner


def test_force_over_the_limit_is_a_fault():
    runner = moves_runner()
    runner.tick()
    runner.tick()
    runner.cell.world.arm.external_wrench[:3] = [0.0, 0.0, 200.0]
    result = runner.run()
    assert result.status == "FAULT" and "200.0 N > 150.0 N" in result.message and result.where == "main/go"


def test_a_lost_arm_link_is_a_fault():
    runner = moves_runner()
    runner.tick()
    runner.cell.world.arm.state_stamp = lambda: -1.0  # the arm's state stops arriving
    result = runner.run()
    assert result.status == "FAULT" and "link to the arm lost" in result.message and result.where == "main/go"


def test_unhealthy_perception_stops_the_cell_by_default():
    result = moves_runner(healthy=lambda tick: tick < 5).run()
    assert result.status == "FAULT" and "/fv/left is unhealthy" in result.message and result.where == "main/go"


def test_unhealthy_perception_with_fail_fails_only_a_skill_that_needs_touch():
    runner = moves_runner(Supervision(unhealthy_perception="fail"), healthy=lambda tick: tick < 5)
    result = runner.run()
    # `go` moved on without touch; `feel` stopped the arm and failed, the cell is not latched
    assert result.status == "FAILURE" and result.where == "main/feel"
    assert "perception on /fv/left is unhealthy" in result.message
    assert runner.cell.arm.pose()[0] == pytest.approx(0.3, abs=1e-6)
    assert not runner.cell.arm.is_moving() and runner.cell.arm.fault() is None


def test_a_fault_through_the_cli_exits_3_and_is_in_the_log_and_the_summary(tmp_path, capsys, monkeypatch):
    from drivers.sim.devices import gripper as sim_gripper

    def step(self, dt, original=sim_gripper.SimGripper.step):
        if self.object_width is not None:  # the first grasp: the motor overheats
            self.fault_text = "overcurrent"
        original(self, dt)

    monkeypatch.setattr(sim_gripper.SimGripper, "step", step)
    assert main(["run", ASSEMBLY, "--runs-dir", str(tmp_path), "--no-plots"]) == 3
    out = capsys.readouterr().out
    assert out.startswith("FAULT: gripper fault:") and "overcurrent" in out
    run_dir = next(tmp_path.iterdir())
    halted = [e for e in map(json.loads, (run_dir / "events.jsonl").read_text().splitlines()) if e["event"] == "halted"]
    assert halted[0]["status"] == "FAULT" and "overcurrent" in halted[0]["message"]
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["status"] == "FAULT" and "overcurrent" in summary["gripper_fault"]


def test_a_wall_clock_cell_waits_for_fresh_perception_before_the_first_tick():
    """The first frames after start-up are from before the run (calibration, setting the tree up):
    the runner waits for fresh ones instead of tripping the first tick on them."""
    import time

    from drivers.clock import WallClock

    cell = mock_cell()
    cell.clock = cell.arm.clock = cell.arm.inner.clock = cell.gripper.clock = WallClock(1 / 30)
    old = cell.clock.now() - 10.0  # frames from before the run
    fresh_from = time.monotonic() + 0.5

    def sense() -> dict:
        stamp = cell.clock.now() if time.monotonic() > fresh_from else old
        return {f: touch(f, stamp=stamp) for f in ("left", "right")}

    doc = load_tree(text="version: 1\nname: t\nroot: {skill: move_to, name: m, params: {offset: [0, 0, 0.001]}}\n")
    runner = Runner(build(doc), cell, sense=sense, supervision=Supervision())
    runner.setup()
    assert time.monotonic() > fresh_from  # setup waited
    result = runner.run()
    assert result.status == "SUCCESS", result.message


def test_supervision_settings_come_from_the_cell_file(tmp_path):
    assert Supervision.of_cell("sim") == Supervision()
    cell = tmp_path / "cell.yaml"
    cell.write_text("kind: sim\nsupervision:\n  perception_stale_after: 0.5\n  unhealthy_perception: fail\n")
    assert Supervision.of_cell(str(cell)) == replace(Supervision(), perception_stale_after=0.5,
                                                     unhealthy_perception="fail")
    cell.write_text("kind: sim\nsupervision:\n  perception_stale_after: -0.1\n")
    with pytest.raises(CellFileError) as err:
        Supervision.of_cell(str(cell))
    assert err.value.line == 3 and "positive number" in err.value.message
    cell.write_text("kind: sim\nsupervision:\n  unhealty_perception: stop\n")
    with pytest.raises(CellFileError) as err:
        Supervision.of_cell(str(cell))
    assert err.value.line == 3 and "unhealthy_perception" in str(err.value.hint)


@pytest.mark.parametrize("lead", [0.1, 0.5])
def test_perception_freezing_just_before_contact_never_presses_harder_than_a_normal_contact(lead):
    """descend_until_contact also watches the arm's force readback, and the supervisor the age of
    the fingertip states: a stream that freezes `lead` s before the normal contact never lets the
    element press harder than it does in a normal run."""
    _, normal, _ = supervised_assembly(max_time=90.0)
    descent = [(t, f) for t, tip, f, _ in normal.rows if tip.endswith("/descend")]
    contact_at, normal_peak = descent[-1][0], max(f for _, f in descent)

    def freeze(rec):
        if rec.frozen is None and rec.cell.clock.now() >= contact_at - lead and rec.runner.tip.path.endswith("/descend"):
            rec.freeze()

    runner, recorder, result = supervised_assembly(freeze, max_time=90.0)
    assert result.status == "FAULT" and "s old (limit 0.2 s)" in result.message
    pressed = [f for _, tip, f, _ in recorder.rows if tip.endswith("/descend")]
    assert max(pressed) <= normal_peak + 1e-6
    assert_cell_stopped(runner)
