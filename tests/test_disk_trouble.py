"""Disk trouble is an error or a fault, never a crash: under a file-size limit (RLIMIT_FSIZE, as
`ulimit -f` sets it, in a process of its own) and with writes that find the disk full (ENOSPC,
injected), the run directory that cannot be made is a located error (exit 2), an as-built record
that cannot be written stops the cell (FAULT, exit 3), and the transition log and the recording
stop instead of the run, with the summary saying what was lost. Before: `error: OSError: [Errno
28] No space left on device` or `RuntimeError: File-writer thread shut down prematurely`, exit 1."""

from __future__ import annotations

import errno
import json
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from assembly.cli import main
from assembly.design import bridge as bridge_module
from assembly.run import storage as storage_module
from assembly.run import transitions
from assembly.run.options import RunOptions
from assembly.run.session import run_tree
from assembly.run.storage import RunStorage
from fvfiles.json_files import append_json_line

ROOT = Path(__file__).resolve().parents[1]
ASSEMBLY = str(ROOT / "trees" / "assembly.yaml")


def run_limited(limit_bytes: int, runs: Path, *extra: str) -> subprocess.CompletedProcess:
    """`fvtree run` of the assembly in a process whose files may grow to `limit_bytes` at most."""
    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, resource.RLIM_INFINITY))

    return subprocess.run([sys.executable, "-m", "assembly.cli", "run", ASSEMBLY, "--runs-dir", str(runs),
                           "--no-plots", *extra], cwd=ROOT, preexec_fn=limit, capture_output=True, text=True,
                          timeout=600, check=False)


def events(run_dir: Path) -> list[dict]:
    return [json.loads(line) for line in (run_dir / "events.jsonl").read_text().splitlines()]


@pytest.mark.slow
def test_a_file_size_limit_stops_the_logs_not_the_run(tmp_path):
    """2 KiB a file: the recording never starts, the transition log stops, every as-built record is kept."""
    done = run_limited(2048, tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Traceback" not in done.stderr
    run_dir = next(tmp_path.iterdir())
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["status"] == "SUCCESS"
    assert [e["element"] for e in events(run_dir) if e["event"] == "placed"] == ["E1", "E2"]
    lost = summary["lost"]
    assert "recording.rrd: not written (the file-size limit (ulimit -f) is 2 KiB)" in lost
    assert any(x.startswith("transitions.jsonl: not written from tick ") and x.endswith("(File too large (EFBIG))")
               for x in lost), lost
    assert "  lost: transitions.jsonl: not written from tick" in done.stdout
    assert not (run_dir / "recording.rrd").exists() and not (run_dir / ".reserve").exists()


@pytest.mark.slow
def test_a_recording_stops_before_the_file_size_limit(tmp_path):
    """Before: Rerun's file writer died at the limit and its flush ended the run, exit 1. The
    recording grows by batches of ticks (the first about 0.9 MB here): it stops when the next
    batch, as large as twice the largest so far, would not fit under the limit."""
    done = run_limited(2 << 20, tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    run_dir = next(tmp_path.iterdir())
    lost = json.loads((run_dir / "summary.json").read_text())["lost"]
    assert len(lost) == 1 and lost[0].startswith("recording.rrd: not written from tick "), lost
    assert "the file-size limit (ulimit -f) is 2048 KiB" in lost[0]
    assert 0 < (run_dir / "recording.rrd").stat().st_size < 2 << 20


@pytest.mark.slow
def test_an_as_built_record_that_cannot_be_written_stops_the_cell(tmp_path):
    """1 KiB a file: the first placement outgrows asbuilt.json; the run ends FAULT with the record's place."""
    done = run_limited(1024, tmp_path)
    assert done.returncode == 3, done.stderr[-3000:]
    assert "Traceback" not in done.stderr
    first = done.stdout.splitlines()[0]
    assert first.startswith("FAULT: ") and "asbuilt.json: cannot write the as-built model (File too large)" in first
    assert "the placing record of E1 is in " in first
    run_dir = next(tmp_path.iterdir())
    assert [e["event"] for e in events(run_dir)][:2] == ["start", "placing"]  # every line whole


@pytest.mark.slow
def test_no_room_for_the_run_directory_is_a_located_error(tmp_path):
    done = run_limited(0, tmp_path)
    assert done.returncode == 2, done.stderr[-3000:]
    assert f"{tmp_path}: cannot write the run directory: File too large (EFBIG)" in done.stderr
    assert "Traceback" not in done.stderr and "ulimit -f" in done.stderr


# ---- ENOSPC, injected -----------------------------------------------------------------------

QUIET = {"quiet": True, "plots": False}


def test_a_full_disk_at_the_transition_log_loses_the_log_not_the_run(tmp_path, monkeypatch):
    """Before: the first failed write of the transition log ended the run at tick 1, exit 1."""
    real_open, seen = open, {}

    class FullDisk:
        def __init__(self, file):
            self.file = file

        def write(self, text):
            seen["reserve"] = (tmp_path / next(tmp_path.iterdir()).name / ".reserve").exists()
            raise OSError(errno.ENOSPC, "No space left on device")

        def __getattr__(self, name):
            return getattr(self.file, name)

    monkeypatch.setattr(transitions, "open", lambda *a, **k: FullDisk(real_open(*a, **k)), raising=False)
    summary = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, record=False, **QUIET))
    assert summary.status == "SUCCESS"
    assert summary.lost == ["transitions.jsonl: not written from tick 0 (No space left on device (ENOSPC))"]
    assert seen["reserve"]  # the reserve was there until the disk filled, and is given back
    run_dir = Path(summary.run_dir)
    assert not (run_dir / ".reserve").exists()
    assert json.loads((run_dir / "summary.json").read_text())["lost"] == summary.lost


def test_a_full_disk_at_the_as_built_model_stops_the_cell(tmp_path, monkeypatch, capsys):
    """Before: RuntimeError in a tick, CRASHED (or `error: OSError`, exit 1)."""
    real_write, calls = bridge_module.atomic_write_json, []

    def write(path, data):
        calls.append(path)
        if len(calls) > 1:  # the model written when the run starts; then the disk is full
            raise OSError(errno.ENOSPC, "No space left on device")
        real_write(path, data)

    monkeypatch.setattr(bridge_module, "atomic_write_json", write)
    assert main(["run", ASSEMBLY, "--runs-dir", str(tmp_path), "--no-plots", "--no-record"]) == 3
    out, err = capsys.readouterr()
    assert out.startswith("FAULT: ") and "asbuilt.json: cannot write the as-built model (No space left on device); " \
                                         "the placing record of E1 is in " in out
    assert "Traceback" not in err
    assert any(e["event"] == "placing" for e in events(next(tmp_path.iterdir())))


def test_a_full_disk_under_the_recording_stops_it_first(tmp_path, monkeypatch):
    """The recording (megabytes) never takes the room the as-built records (kilobytes) need."""
    monkeypatch.setattr(storage_module, "LOW_SPACE_BYTES", 1 << 62)  # any disk is nearly full then
    summary = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, **QUIET))
    assert summary.status == "SUCCESS"
    assert len(summary.lost) == 1 and summary.lost[0].startswith("recording.rrd: not written (only ")
    assert summary.lost[0].endswith("MiB free on the disk, kept for the as-built records)")
    assert not (Path(summary.run_dir) / "recording.rrd").exists()


def test_the_reserve_is_set_aside_and_given_back(tmp_path):
    storage = RunStorage(tmp_path, reserve=1 << 20)
    assert (tmp_path / ".reserve").stat().st_blocks * 512 >= 1 << 20  # allocated, not sparse
    storage.lost("x.log", OSError(errno.EACCES, "Permission denied"))
    assert (tmp_path / ".reserve").exists()  # not a full disk: kept
    storage.lost("y.log", OSError(errno.ENOSPC, "No space left on device"), since="tick 3")
    assert not (tmp_path / ".reserve").exists()
    assert storage.notes == ["x.log: not written (Permission denied (EACCES))",
                             "y.log: not written from tick 3 (No space left on device (ENOSPC))"]


def test_a_failed_append_leaves_no_torn_line(tmp_path, monkeypatch):
    log = tmp_path / "events.jsonl"
    append_json_line(log, {"event": "start"})
    real_write = __import__("os").write

    def half_then_full(fd, data):
        monkeypatch.setattr("os.write", real_write)
        real_write(fd, data[: len(data) // 2])
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("os.write", half_then_full)
    with pytest.raises(OSError, match="No space left"):
        append_json_line(log, {"event": "placing", "element": "E1"})
    assert log.read_text() == '{"event": "start"}\n'


def test_a_full_disk_with_no_file_named_is_still_an_error_not_a_traceback(monkeypatch, capsys):
    from assembly.run import session

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(session, "run_tree", full)
    assert main(["run", ASSEMBLY]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cannot write: No space left on device (ENOSPC)") and "Traceback" not in err


def test_a_dataset_that_cannot_be_written_is_a_located_error_with_no_file_left(tmp_path, monkeypatch, capsys):
    from perception.learning import dataset

    def full(self, path):
        Path(path).write_bytes(b"PK\x03\x04 half")  # what a full disk leaves: the start of the file
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(dataset.Dataset, "save", full)
    out = tmp_path / "data.npz"
    code = main(["record", str(ROOT / "trees" / "record_press.yaml"), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and f"{out}: cannot write the dataset: No space left on device (ENOSPC)" in err
    assert not out.exists()
