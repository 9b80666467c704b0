"""Every run writes an event log, with or without a design: `events.jsonl` in its run directory,
beginning with a `start` record and ending with an `end` record (status, where, message), each
stamped as a design run's records are (wall `time`, tick, cell time `t`, element in work). Before:
a tree without a design (the hold demo) wrote no `events.jsonl`, though the README said every run
does; its halt and end reached only the recording. A design-less run still cannot be resumed (it
has no as-built records): that is unchanged."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from assembly.errors import TreeError
from assembly.language.reader import load_tree
from assembly.outcome.outline import render
from assembly.run.options import RunOptions
from assembly.run.session import run_tree

ROOT = Path(__file__).resolve().parents[1]
HOLD = str(ROOT / "trees" / "hold.yaml")
QUIET = {"quiet": True, "plots": False, "record": False}


def lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_a_design_less_run_to_its_end_logs_start_and_end(tmp_path):
    began = time.time()
    summary = run_tree(HOLD, RunOptions(runs_dir=tmp_path, seed=3, perception="signals", **QUIET))
    run_dir = Path(summary.run_dir)
    assert not (run_dir / "asbuilt.json").exists()  # no design, no as-built records
    events = lines(run_dir / "events.jsonl")
    assert [e["event"] for e in events] == ["start", "end"]
    start, end = events
    assert {k: start[k] for k in ("tree", "cell", "seed", "resume", "tick", "t", "element")} == {
        "tree": HOLD, "cell": "sim", "seed": 3, "resume": False, "tick": 0, "t": 0.0, "element": None}
    assert end["status"] == summary.status and end["where"] and "message" in end
    assert end["tick"] == summary.ticks and end["t"] == pytest.approx(summary.sim_time_s, abs=0.05)
    assert began <= start["time"] <= end["time"] <= time.time()
    # the `end` record holds the status after the scene's verdict, as summary.json does
    assert end["status"] == json.loads((run_dir / "summary.json").read_text())["status"]


def test_a_design_less_run_stopped_logs_the_halt_between_start_and_end(tmp_path):
    summary = run_tree(HOLD, RunOptions(runs_dir=tmp_path, max_time=1.0, **QUIET))
    events = lines(Path(summary.run_dir) / "events.jsonl")
    assert [e["event"] for e in events] == ["start", "halted", "end"]
    halted, end = events[1:]
    assert summary.status == end["status"] == "TIMEOUT" and halted["node"] == end["where"]
    assert halted["t"] >= 1.0 and halted["tick"] <= end["tick"] and "no result within 1.0 s" in halted["message"]
    # the transition log and the event log line up: the halt's tick is that of the transitions it caused
    stopped = [r for r in lines(Path(summary.run_dir) / "transitions.jsonl") if r["tick"] == halted["tick"]]
    assert stopped and all(r["to"] == "INVALID" and r["t"] == halted["t"] for r in stopped)


def test_a_design_less_run_is_still_not_resumed(tmp_path):
    """Unchanged by its event log: a run with no as-built records has nothing to resume."""
    summary = run_tree(HOLD, RunOptions(runs_dir=tmp_path, max_time=0.5, **QUIET))
    log = Path(summary.run_dir) / "events.jsonl"
    before = log.read_bytes()
    with pytest.raises(TreeError, match="no earlier run of 'hold_demo' to resume"):
        run_tree(HOLD, RunOptions(runs_dir=tmp_path, resume="latest", **QUIET))
    with pytest.raises(TreeError, match="not a run directory"):
        run_tree(HOLD, RunOptions(runs_dir=tmp_path, resume=summary.run_dir, **QUIET))
    assert log.read_bytes() == before  # nothing appended by the refused sessions


def test_a_run_without_a_run_directory_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    summary = run_tree(HOLD, RunOptions(runs_dir=None, max_time=0.5, **QUIET))
    assert summary.run_dir is None and list(tmp_path.iterdir()) == []


def test_show_run_tells_a_node_stopped_while_running_from_one_never_ticked(tmp_path):
    """`fvtree show --run`: the grasp the time limit stopped is '■', the lift and hold never ticked
    are '-' (before, both printed '-')."""
    summary = run_tree(HOLD, RunOptions(runs_dir=tmp_path, max_time=1.0, **QUIET))
    shown = render(load_tree(HOLD), Path(summary.run_dir)).splitlines()
    mark = {name: next(x for x in shown if f" {name} [" in x).split(f" {name} [")[0][-1] for name in
            ("hold_demo", "grasp", "lift", "hold")}
    assert mark == {"hold_demo": "■", "grasp": "■", "lift": "-", "hold": "-"}, shown
