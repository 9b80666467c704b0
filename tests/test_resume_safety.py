"""Runs that cannot race or stop short: one session at a time per run directory (a second
`--resume` is refused, exit 2), a run stopped after its last placement resumes to finish the tree,
`--resume` takes the run started last (not the lexically last name), and a hand-edited event log
is refused with its file, line and field instead of being replayed onto the cell."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from assembly.cli import main
from assembly.errors import TreeError
from assembly.language.reader import load_tree
from assembly.run import run_dir as run_dirs
from assembly.run.options import RunOptions
from assembly.run.run_lock import RunDirBusy, RunLock
from assembly.run.session import Run, run_tree
from fvfiles.json_files import atomic_write_json

ROOT = Path(__file__).resolve().parents[1]
ASSEMBLY = str(ROOT / "trees" / "assembly.yaml")
QUIET = {"quiet": True, "plots": False, "record": False}


def lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def placings(run_dir: Path) -> dict[str, int]:
    counts: dict[str, int] = {}
    for e in lines(run_dir / "events.jsonl"):
        if e["event"] == "placing":
            counts[e["element"]] = counts.get(e["element"], 0) + 1
    return counts


@pytest.fixture(scope="module")
def stopped_after_e1(tmp_path_factory) -> Path:
    """A run e-stopped at 140 s of cell time: E1 placed (119 s), E2 not begun (copied by each test)."""
    runs = tmp_path_factory.mktemp("runs")
    first = run_tree(ASSEMBLY, RunOptions(runs_dir=runs, estop_at=140.0, **QUIET))
    assert first.status == "ESTOP" and placings(Path(first.run_dir)) == {"E1": 1}
    return Path(first.run_dir)


def copy_run(run_dir: Path, tmp_path: Path) -> Path:
    runs = tmp_path / "runs"
    runs.mkdir()
    subprocess.run(["cp", "-a", str(run_dir), str(runs)], check=True)
    return runs


# ---- the lock -------------------------------------------------------------------------------

def test_a_second_session_of_a_run_is_refused_while_the_first_holds_it(stopped_after_e1, tmp_path, capsys):
    runs = copy_run(stopped_after_e1, tmp_path)
    with Run(ASSEMBLY, RunOptions(runs_dir=runs, resume="latest", **QUIET)) as first:
        assert main(["run", ASSEMBLY, "--runs-dir", str(runs), "--resume", "--no-record", "--no-plots"]) == 2
        err = capsys.readouterr().err
        assert f"{first.run_dir}: another fvtree run (pid " in err and "is using this run directory" in err
        assert "Traceback" not in err
        summary = first.run()
    assert summary.status == "SUCCESS"
    assert placings(first.run_dir) == {"E1": 1, "E2": 1}
    with RunLock(first.run_dir):  # freed when the session closed
        pass


def test_a_failed_resume_frees_the_lock(stopped_after_e1, tmp_path):
    runs = copy_run(stopped_after_e1, tmp_path)
    with pytest.raises(TreeError, match="--mark E9=placed: no element 'E9'"):
        run_tree(ASSEMBLY, RunOptions(runs_dir=runs, resume="latest", marks={"E9": "placed"}, **QUIET))
    with RunLock(next(runs.iterdir())):
        pass


def test_the_lock_is_exclusive_between_processes(tmp_path):
    holder = subprocess.Popen([sys.executable, "-c", ("import fcntl, os, sys, time\n"
                               f"fd = os.open({str(tmp_path / '.lock')!r}, os.O_RDWR | os.O_CREAT)\n"
                               "fcntl.flock(fd, fcntl.LOCK_EX); os.write(fd, b'%d' % os.getpid())\n"
                               "print('held', flush=True); sys.stdin.read()")],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline() == "held\n"
        with pytest.raises(RunDirBusy, match=f"pid {holder.pid}"):
            RunLock(tmp_path).acquire()
    finally:
        holder.communicate("")
    with RunLock(tmp_path):  # the holder ended: the kernel dropped its lock
        pass


RESUME = [sys.executable, "-m", "assembly.cli", "run", ASSEMBLY, "--no-plots", "--no-record", "--resume"]


@pytest.mark.slow
def test_two_resumes_started_at_once_place_the_last_element_once(stopped_after_e1, tmp_path):
    """The issue's reproducer: two `fvtree run --resume` of one run at once placed E2 twice."""
    runs = copy_run(stopped_after_e1, tmp_path)
    both = [subprocess.Popen([*RESUME, "--runs-dir", str(runs)], cwd=ROOT, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outcomes = sorted((p.wait(timeout=600), p.communicate()) for p in both)
    codes = [code for code, _ in outcomes]
    run_dir = next(runs.iterdir())
    assert placings(run_dir) == {"E1": 1, "E2": 1}, outcomes
    if codes == [0, 2]:  # they overlapped: the second was refused
        assert "is using this run directory" in outcomes[1][1][1]
    else:  # one ended before the other took the lock: the later one had nothing left to do
        assert codes == [0, 0] and any("nothing to do" in out for _, (out, _) in outcomes), outcomes


# ---- stopping short -------------------------------------------------------------------------

def test_a_run_stopped_after_its_last_placement_resumes_to_finish_the_tree(tmp_path):
    """Before: 'nothing to do', and the way home never ran (the arm left under the plate)."""
    full = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path / "full", **QUIET))
    stop = full.sim_time_s - 0.5  # during the way home, after the last placement
    first = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path / "runs", estop_at=stop, **QUIET))
    assert first.status == "ESTOP" and first.where.endswith("/home")
    assert all(e["status"] == "placed" for e in first.elements.values())

    second = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path / "runs", resume="latest", **QUIET))
    assert not second.nothing_to_do and second.status == "SUCCESS" and second.ticks > 0
    run_dir = Path(first.run_dir)
    assert placings(run_dir) == {"E1": 1, "E2": 1}  # finishing built nothing again
    home = [t for t in lines(run_dir / "transitions.jsonl") if t["node"].endswith("/home")]
    assert home[-1]["to"] == "SUCCESS"
    assert second.elements == first.elements

    third = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path / "runs", resume="latest", **QUIET))
    assert third.nothing_to_do and third.status == "SUCCESS"


@pytest.mark.slow
def test_a_run_killed_after_its_last_placement_resumes_to_finish_the_tree(tmp_path, capsys):
    """kill -9 while the arm backs out of the last element (after its `placed` record): the resume
    runs the rest of the tree instead of answering 'nothing to do'."""
    from test_fail_safe import KILL_AT  # the kill -9 at a cell time, shared with the fail-safe tests

    full = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path / "full", **QUIET))
    place = [t for t in lines(Path(full.run_dir) / "transitions.jsonl")
             if t["node"].endswith("/prop/place") and t["to"] == "SUCCESS"][-1]["t"]  # E2 placed, then backed out
    args = ["run", ASSEMBLY, "--runs-dir", str(tmp_path / "runs"), "--no-plots", "--no-record"]
    killed = subprocess.run([sys.executable, "-c", KILL_AT, str(place - 0.3), *args], cwd=ROOT,
                            capture_output=True, text=True, check=False)
    assert killed.returncode == -9, killed.stderr[-2000:]
    run_dir = next((tmp_path / "runs").iterdir())
    assert placings(run_dir) == {"E1": 1, "E2": 1} and not (run_dir / "summary.json").exists()
    assert main([*args, "--resume"]) == 0
    out = capsys.readouterr().out
    assert "nothing to do" not in out and out.startswith("SUCCESS")
    assert placings(run_dir) == {"E1": 1, "E2": 1}
    ends = [e for e in lines(run_dir / "events.jsonl") if e["event"] in ("start", "end")]
    assert [e["event"] for e in ends] == ["start", "start", "end"] and ends[-1]["status"] == "SUCCESS"


# ---- the latest run -------------------------------------------------------------------------

def test_resume_takes_the_run_started_last_not_the_last_name(tmp_path, monkeypatch):
    """Eleven runs started in one second are named -1 .. -10: `-9` sorts after `-10` by name."""
    doc = load_tree(ASSEMBLY)
    monkeypatch.setattr(run_dirs.time, "strftime", lambda fmt: "20260101-000000")
    made = []
    for _ in range(11):
        run_dir = run_dirs.new_run_dir(tmp_path, doc.name)
        run_dirs.write_run_file(run_dir, doc)
        atomic_write_json(run_dir / run_dirs.ASBUILT_FILE, doc.design.to_data())
        made.append(run_dir)
    assert made[-1].name.endswith("-10") and max(made).name.endswith("-9")
    assert run_dirs.find_run(tmp_path, "latest", doc) == made[-1]

    data = json.loads((made[4] / "run.json").read_text())  # a run from before `started`: its file's time
    del data["started"]
    atomic_write_json(made[4] / "run.json", data)
    assert run_dirs.find_run(tmp_path, "latest", doc) == made[4]


# ---- the event log --------------------------------------------------------------------------

def edited(stopped: Path, tmp_path: Path, edit) -> Path:
    """A copy of the stopped run whose event log `edit(records) -> lines` rewrote."""
    runs = copy_run(stopped, tmp_path)
    log = next(runs.iterdir()) / "events.jsonl"
    log.write_text("".join(line + "\n" for line in edit(lines(log))))
    return runs


def refused(runs: Path, capsys) -> str:
    assert main(["run", ASSEMBLY, "--runs-dir", str(runs), "--resume", "--no-record", "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    return err


def placed_line(records: list[dict]) -> int:
    return next(i for i, r in enumerate(records) if r["event"] == "placed")


def with_placed(records: list[dict], **change) -> list[str]:
    i = placed_line(records)
    records[i] = {**records[i], **change}
    return [json.dumps(r) for r in records]


def test_a_nan_pose_in_the_event_log_is_refused_with_its_line(stopped_after_e1, tmp_path, capsys):
    runs = edited(stopped_after_e1, tmp_path, lambda rs: with_placed(rs, pose=[math.nan, 0, 0.1, 0, 0, 0]))
    number = placed_line(lines(next(runs.iterdir()) / "events.jsonl")) + 1
    err = refused(runs, capsys)
    assert f"events.jsonl:{number}: pose: must be a pose of 6 finite numbers" in err and "NaN" in err
    asbuilt = json.loads((next(runs.iterdir()) / "asbuilt.json").read_text())
    assert "NaN" not in json.dumps(asbuilt)  # nothing was replayed


def test_a_pose_outside_the_cells_box_is_refused(stopped_after_e1, tmp_path, capsys):
    runs = edited(stopped_after_e1, tmp_path, lambda rs: with_placed(rs, pose=[0.5, 0.0, -3.0, 0, 0, 0]))
    err = refused(runs, capsys)
    assert ": pose: position [0.5, 0.0, -3.0] is outside the cell's safety box [-0.9, -0.9, 0.0] .. [0.9, 0.9, 0.9]" in err


def test_a_planned_mark_of_a_placed_element_is_refused(stopped_after_e1, tmp_path, capsys):
    """Before: the mark was replayed and E1, standing, was built a second time."""
    def unplace(records):
        mark = {"time": records[-1]["time"], "event": "marked", "element": "E1", "status": "planned",
                "pose": records[placed_line(records)]["pose"], "load": None}
        return [json.dumps(r) for r in [*records, mark]]

    runs = edited(stopped_after_e1, tmp_path, unplace)
    number = len(lines(next(runs.iterdir()) / "events.jsonl"))
    err = refused(runs, capsys)
    assert f"events.jsonl:{number}: event: marked planned of E1, which is 'placed' by then: this would build it " \
           "a second time" in err


@pytest.mark.parametrize(("line", "field", "message"), [
    ("[1, 2]", "", "not a JSON object"),
    ('{"event": "start"}', "time: ", "must be a finite number, got null"),
    ('{"time": 1, "event": "placed", "element": "E7", "status": "placed"}', "element: ", "no element \"E7\""),
    ('{"time": 1, "event": "placing", "element": "E2", "status": "placed", "pose": null}', "status: ",
     "a placing record has status placing"),
    ("root:$6$x:19000:0:99999:7:::", "", "not a JSON record"),
])
def test_a_damaged_line_is_named_by_its_number_and_field(stopped_after_e1, tmp_path, capsys, line, field, message):
    runs = edited(stopped_after_e1, tmp_path, lambda rs: [json.dumps(rs[0]), line, *map(json.dumps, rs[1:])])
    err = refused(runs, capsys)
    assert f"events.jsonl:2: {field}{message}" in err
    assert "root:$6$" not in err  # a line is never quoted whole


def test_a_torn_last_line_is_what_a_crash_leaves_and_is_ignored(stopped_after_e1, tmp_path):
    runs = copy_run(stopped_after_e1, tmp_path)
    log = next(runs.iterdir()) / "events.jsonl"
    log.write_text(log.read_text() + '{"time": 1, "event": "plac')
    summary = run_tree(ASSEMBLY, RunOptions(runs_dir=runs, resume="latest", **QUIET))
    assert summary.status == "SUCCESS" and placings(log.parent) == {"E1": 1, "E2": 1}
    assert all(isinstance(json.loads(line), dict) for line in log.read_text().splitlines())
