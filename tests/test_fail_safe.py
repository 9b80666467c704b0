"""The fail-safe tick loop: an exception anywhere in a tick halts the tree, stops arm and gripper,
logs a `crashed` event and writes the summary; SIGTERM halts like Ctrl-C; a run directory that
cannot be written stops the run (FAULT) with the placement kept in the event log; kill -9 at any moment
never makes a resumed run place an element twice."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from assembly.cli import main
from assembly.design import bridge as bridge_module
from assembly.language.build import build
from assembly.language.reader import load_tree
from assembly.run.loop import Runner
from assembly.run.options import RunOptions
from assembly.run.session import run_tree
from behaviours.vis_scan import VisScan
from drivers.cell_builders import load_cell

ROOT = Path(__file__).resolve().parents[1]
ASSEMBLY = str(ROOT / "trees" / "assembly.yaml")
PYTHON = sys.executable


def lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def assembly_runner(run_dir=None, sense=None) -> Runner:
    doc = load_tree(ASSEMBLY)
    cell = load_cell("sim", doc.tick_hz, doc.scene, doc.design.scene_args())
    runner = Runner(build(doc), cell, run_dir, sense=sense)
    runner.setup()
    return runner


def test_a_skill_raising_mid_tick_leaves_arm_and_gripper_stopped(tmp_path):
    runner = assembly_runner(tmp_path)
    while not runner.tip.path.endswith("/grasp") or not runner.cell.gripper.is_moving():
        runner.tick()
    grasp = runner.tree.nodes["main/assemble/elements/build/prop/pick/pick_once/grasp"]
    terminated = []
    grasp.update = lambda: 1 / 0
    grasp.terminate = lambda status, original=grasp.terminate: (terminated.append(status), original(status))
    result = runner.run()
    assert result.status == "CRASHED" and result.where.endswith("/pick_once/grasp")
    assert result.message == "ZeroDivisionError: division by zero (in main/assemble/elements/build/prop/pick/pick_once/grasp)"
    assert "ZeroDivisionError" in result.traceback
    assert terminated and not runner.cell.arm.is_moving() and not runner.cell.gripper.is_moving()
    assert all(node.status.name == "INVALID" for node in runner.tree.nodes.values())
    assert lines(tmp_path / "transitions.jsonl")[-1]["to"] == "INVALID"


def test_a_handler_raising_halts_the_run_at_the_running_node():
    def broken_sense():
        if runner.ticks == 50:
            raise OSError("camera unplugged")
        return runner.cell.sense()

    runner = assembly_runner(sense=broken_sense)
    result = runner.run()
    assert result.status == "CRASHED" and result.message.startswith("OSError: camera unplugged (in main/")
    assert result.where and not runner.cell.arm.is_moving() and not runner.cell.gripper.is_moving()


def test_a_raising_terminate_does_not_keep_the_others_or_the_devices_running():
    runner = assembly_runner()
    while not runner.tip.path.endswith("/scan"):
        runner.tick()
    scan = runner.tree.nodes["main/assemble/elements/build/prop/pick/pick_once/scan"]
    scan.terminate = lambda status: 1 / 0
    runner.halt()
    assert not runner.cell.arm.is_moving() and not runner.cell.gripper.is_moving()
    assert all(node.status.name == "INVALID" for path, node in runner.tree.nodes.items() if not path.endswith("/scan"))


@pytest.fixture
def crashing_scan(monkeypatch):
    """VisScan raises on its 40th tick."""
    calls = []

    def update(self, original=VisScan.update):
        calls.append(1)
        if len(calls) == 40:
            raise RuntimeError("lost the marker field")
        return original(self)

    monkeypatch.setattr(VisScan, "update", update)


def test_a_crashed_run_logs_the_crash_writes_the_summary_and_exits_non_zero(tmp_path, capsys, crashing_scan):
    assert main(["run", ASSEMBLY, "--runs-dir", str(tmp_path), "--no-plots"]) == 4
    captured = capsys.readouterr()
    assert captured.out.startswith("CRASHED: RuntimeError: lost the marker field (in main/assemble/")
    assert "Traceback" not in captured.out + captured.err
    run_dir = next(tmp_path.iterdir())
    crashed = [e for e in lines(run_dir / "events.jsonl") if e["event"] == "crashed"]
    assert crashed[0]["node"].endswith("/pick_once/scan") and "RuntimeError" in crashed[0]["traceback"]
    assert lines(run_dir / "events.jsonl")[-1]["event"] == "end"
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["status"] == "CRASHED" and summary["where"].endswith("/scan")


def test_debug_shows_the_traceback_of_a_crash(tmp_path, capsys, crashing_scan):
    assert main(["--debug", "run", ASSEMBLY, "--runs-dir", str(tmp_path), "--no-plots"]) == 4
    assert "Traceback (most recent call last)" in capsys.readouterr().err


@pytest.mark.slow
def test_sigterm_halts_the_run_like_ctrl_c(tmp_path):
    proc = subprocess.Popen([PYTHON, "-m", "assembly.cli", "run", ASSEMBLY, "--runs-dir", str(tmp_path),
                             "--no-plots", "--speed", "realtime"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not any(p.stat().st_size for p in tmp_path.glob("*/transitions.jsonl")) and time.monotonic() < deadline:
        time.sleep(0.1)  # the first tick's transitions are written: the tick loop runs (setup can take seconds)
    time.sleep(1.0)  # well into the first skill
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, err
    assert out.startswith("HALTED: interrupted (SIGTERM) during main/"), out + err
    run_dir = next(tmp_path.iterdir())
    assert [e["event"] for e in lines(run_dir / "events.jsonl")][-2:] == ["halted", "end"]
    assert json.loads((run_dir / "summary.json").read_text())["status"] == "HALTED"


def test_sigterm_while_the_run_is_set_up_closes_the_cell_like_ctrl_c(tmp_path, monkeypatch):
    """SIGTERM before the tick loop (the cell built, the tree being built) interrupts the run like
    Ctrl-C: the cell is closed, the command ends 130 'interrupted', and the handler is put back."""
    closed = []
    real_load_cell, real_build = load_cell, build

    def watched_cell(*args, **kwargs):
        cell = real_load_cell(*args, **kwargs)
        close = cell.close
        cell.close = lambda: (closed.append(True), close())[1]
        return cell

    def build_then_sigterm(doc):
        signal.raise_signal(signal.SIGTERM)  # arrives while the session sets the run up
        return real_build(doc)

    monkeypatch.setattr("assembly.run.session.load_cell", watched_cell)
    monkeypatch.setattr("assembly.run.session.build", build_then_sigterm)
    before = signal.getsignal(signal.SIGTERM)
    assert main(["run", ASSEMBLY, "--runs-dir", str(tmp_path), "--no-plots"]) == 130
    assert closed == [True] and signal.getsignal(signal.SIGTERM) is before


def test_a_failed_as_built_write_halts_the_run_with_the_placement_in_the_log(tmp_path, monkeypatch):
    writes = []

    def read_only(path, data, original=bridge_module.atomic_write_json):
        writes.append(path)
        if len(writes) > 1:  # the run directory turns read-only after the start
            raise PermissionError(13, "Permission denied", str(path))
        original(path, data)

    monkeypatch.setattr(bridge_module, "atomic_write_json", read_only)
    summary = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, quiet=True, plots=False))
    assert summary.status == "FAULT" and "cannot write the as-built model" in summary.message
    assert "the placing record of E1 is in" in summary.message and summary.where.endswith("/elements")
    run_dir = Path(summary.run_dir)
    events = lines(run_dir / "events.jsonl")
    assert next(e["event"] for e in events if e.get("element") == "E1") == "placing"
    assert events[-2]["event"] == "halted" and events[-2]["status"] == "FAULT"


def test_when_the_event_log_fails_too_the_placement_goes_to_stderr(tmp_path, monkeypatch, capsys):
    from fvfiles import json_files

    def fail(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    original = bridge_module.DesignBridge.record_placing

    def record_placing(self, *args):
        monkeypatch.setattr(bridge_module, "atomic_write_json", fail)
        monkeypatch.setattr(json_files, "append_json_line", fail)
        original(self, *args)

    monkeypatch.setattr(bridge_module.DesignBridge, "record_placing", record_placing)
    summary = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, quiet=True, plots=False))
    err = capsys.readouterr().err
    assert summary.status == "FAULT" and "the placing record of E1 is in stderr" in summary.message
    assert '"event": "placing", "element": "E1"' in err


# ---- kill -9 --------------------------------------------------------------------------------

KILL_AT = """
import os, signal, sys
from assembly.run import loop as runner
from assembly.cli import main

at = float(sys.argv.pop(1))
tick = runner.Runner.tick

def tick_until(self):
    if self.cell.clock.now() >= at:
        os.kill(os.getpid(), signal.SIGKILL)
    return tick(self)

runner.Runner.tick = tick_until
sys.exit(main(sys.argv[1:]))
"""


def kill_then_resume(at: float, runs_dir: Path, capsys) -> dict:
    """Run the assembly in a process of its own, kill -9 it at cell time `at`, resume it here
    (playing the person who checks an element left `placing`: it stands), and count the
    placements per element."""
    args = ["run", ASSEMBLY, "--runs-dir", str(runs_dir), "--no-plots"]
    killed = subprocess.run([PYTHON, "-c", KILL_AT, str(at), *args], cwd=ROOT, capture_output=True, text=True, check=False)
    assert killed.returncode == -signal.SIGKILL, killed.stderr[-2000:]
    code = main([*args, "--resume"])
    err = capsys.readouterr().err
    refused = "was being released" in err
    if refused:
        element = err.split("element ", 1)[1].split(" ", 1)[0]
        code = main([*args, "--resume", "--mark", f"{element}=placed"])
        err = capsys.readouterr().err
    assert code == 0, err[-2000:]
    events = lines(next(runs_dir.iterdir()) / "events.jsonl")
    released = {}
    for e in events:
        if e["event"] == "placing":
            released[e["element"]] = released.get(e["element"], 0) + 1
    return {"refused": refused, "released": released}


# Killed before E1's release, while it is being released (its place node starts announcing the
# release at 123.90 s of cell time: a person must check it), and after it stands, with E2 under way.
@pytest.mark.slow
@pytest.mark.parametrize("at, releasing", [(100.0, False), (124.3, True), (150.0, False)])
def test_kill_9_at_any_moment_never_places_an_element_twice(tmp_path, capsys, at, releasing):
    outcome = kill_then_resume(at, tmp_path, capsys)
    assert outcome["released"] == {"E1": 1, "E2": 1}, outcome
    assert outcome["refused"] == releasing  # a release in progress needs a person's check
