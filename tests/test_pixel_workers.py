"""Pixel mode with a fingertip in a worker process (`drivers.sim.models.pixel_workers`): the same
states bit for bit as in one process, the recording's camera frames the same JPEGs (the worker
encodes its own), and a worker that dies or stops answering ends the run FAULT naming its camera,
never a hang or an orphan."""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from assembly.language.build import build
from assembly.language.reader import load_tree
from assembly.observe.recorder import JPEG_QUALITY
from assembly.run.loop import Runner
from assembly.run.perception_stage import clear_blackboard
from assembly.run.supervisor import Supervision
from drivers.camera_frames import frames_of
from drivers.cell_builders import load_cell
from drivers.cell_file import CellFileError, resolve_cell_path
from drivers.protocols import DriverFault
from drivers.sim.models import pixel_workers
from perception.state import TactileState

ROOT = Path(__file__).resolve().parents[1]
HOLD = ROOT / "trees" / "hold.yaml"


def _cell_file(tmp_path: Path, workers) -> str:
    data = yaml.safe_load(resolve_cell_path("sim").read_text())
    data["pixel_workers"] = workers
    path = tmp_path / f"sim_workers_{workers}.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def _run(cell_file: str, seconds: float, at_tick=None):
    """(result, the states of every tick, the cell) of trees/hold.yaml in pixel mode for `seconds` of
    cell time; `at_tick(n, cell)` is called before the n-th tick's perception."""
    doc = load_tree(HOLD)
    clear_blackboard()
    cell = load_cell(cell_file, doc.tick_hz, doc.scene, seed=3, perception="pixels")
    states = []

    def sense():
        if at_tick is not None:
            at_tick(len(states), cell)
        states.append(cell.sense())
        return states[-1]

    try:
        runner = Runner(build(doc), cell, sense=sense, max_time=seconds, supervision=Supervision.of_cell("sim"))
        runner.setup()
        return runner.run(), states, cell
    finally:
        cell.close()


def _same(a, b, where: str) -> None:
    """Every field of two states (nested dataclasses, arrays, floats) equal, bit for bit."""
    if dataclasses.is_dataclass(a):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            _same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), where
    else:
        assert a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b)), (where, a, b)


def test_workers_give_the_in_process_states_bit_for_bit(tmp_path):
    one, alone, _ = _run(_cell_file(tmp_path, False), 10.0)
    two, parallel, cell = _run(_cell_file(tmp_path, True), 10.0)
    assert not cell.sense.processes["right"].is_alive()  # closed with the cell
    assert one.status == two.status and len(alone) == len(parallel) == 301
    for tick, (a, b) in enumerate(zip(alone, parallel)):
        assert list(a) == list(b) == ["left", "right"]
        for finger in a:
            _same(a[finger], b[finger], f"tick {tick} {finger}")
    assert any(s["right"].obj.present for s in parallel) and parallel[-1]["right"].force[1] < -0.5


def _jpegs_after(tmp_path: Path, workers: bool, ticks: int) -> list[dict[str, tuple[bytes, float]]]:
    """The recording's JPEGs of each finger's frame after each of `ticks` ticks of the hold scene in
    pixel mode, with or without `workers`."""
    doc = load_tree(HOLD)
    cell = load_cell(_cell_file(tmp_path, workers), doc.tick_hz, doc.scene, seed=3, perception="pixels")
    try:
        assert list(cell.sense.processes) == (list(pixel_workers.WORKER_FINGERS) if workers else [])
        jpegs = []
        for _ in range(ticks):
            cell.step()
            states = cell.sense()
            jpegs.append(frames_of(cell.sense).jpegs(JPEG_QUALITY))
            assert {finger: stamp for finger, (_, stamp) in jpegs[-1].items()} == {
                finger: state.stamp for finger, state in states.items()}  # the frames of this tick
        return jpegs
    finally:
        cell.close()


def test_the_worker_encodes_its_finger_frame_as_the_main_process_would(tmp_path):
    alone = _jpegs_after(tmp_path, False, 3)
    parallel = _jpegs_after(tmp_path, True, 3)
    assert parallel == alone  # the same JPEG bytes and stamps, at the recorder's quality
    for jpeg, _ in parallel[-1].values():
        image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        assert image.shape == (240, 320, 3) and image.std() > 5  # a rendered skin, not a blank


def test_a_killed_worker_ends_the_run_fault_naming_its_camera(tmp_path):
    def kill_at_60(tick: int, cell) -> None:
        if tick == 60:
            os.kill(cell.sense.processes["right"].pid, signal.SIGKILL)

    result, states, _ = _run(_cell_file(tmp_path, True), 10.0, kill_at_60)
    assert result.status == "FAULT" and len(states) == 61
    assert states[59]["right"].healthy and not states[60]["right"].healthy and states[60]["left"].healthy
    assert "camera right" in result.message and "died (exit code -9)" in result.message, result.message


def test_a_worker_that_stops_answering_is_reported_not_waited_for(tmp_path, monkeypatch):
    def stop_at_30(tick: int, cell) -> None:
        if tick == 30:  # a short reply timeout from now on only: a busy machine may be slow before
            monkeypatch.setattr(pixel_workers, "REPLY_TIMEOUT", 1.0)
            os.kill(cell.sense.processes["right"].pid, signal.SIGSTOP)

    result, states, cell = _run(_cell_file(tmp_path, True), 10.0, stop_at_30)
    assert result.status == "FAULT" and len(states) == 31 and not states[30]["right"].healthy
    assert "camera right" in result.message and "did not answer in 1 s" in result.message, result.message
    assert not cell.sense.processes["right"].is_alive()  # killed: a stopped process ignores SIGTERM


@pytest.mark.slow
def test_workers_leave_when_the_main_process_is_killed():
    """No orphans: the workers see their pipe close and leave, even after SIGKILL of the main process."""
    script = ("import sys, time\nfrom drivers.cell_builders import load_cell\n"
              "cell = load_cell('sim', 30.0, 'hold', perception='pixels')\n"
              "print(*[p.pid for p in cell.sense.processes.values()], flush=True)\ntime.sleep(600)\n")
    main = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        pids = [int(p) for p in main.stdout.readline().split()]
    finally:
        main.kill()
        main.wait()
    assert pids
    deadline = time.monotonic() + 30.0
    while any(_running(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_running(pid) for pid in pids)


def _running(pid: int) -> bool:
    """A process exists and is not a zombie waiting to be reaped."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(") ")[1][0] != "Z"
    except (FileNotFoundError, IndexError):
        return False


class _FailingFinger:
    """A finger processor that raises at start (rig "broken") or on frames stamped 1 s or later."""

    def __init__(self, rig: str):
        if rig == "broken":
            raise RuntimeError("no camera model for 'broken'")
        self.finger = rig

    def process(self, position, size, obj, shift, stamp):
        if stamp >= 1.0:
            raise ValueError(f"frame at {stamp:g} s has no markers")
        return TactileState(self.finger, stamp), np.zeros((4, 4, 3), np.uint8)


def test_a_worker_that_raises_gives_unhealthy_states_naming_the_cause():
    fingers = pixel_workers.FingerWorkers(_FailingFinger, {"left": "left", "right": "right"}, ("right",))
    try:
        frame = (np.zeros((1, 2)), np.ones(1), None, 0.0)
        states = fingers.process({f: (*frame, 0.5) for f in ("left", "right")})
        assert states["right"].healthy and states["right"].stamp == 0.5
        assert [(f, stamp) for f, (_, stamp) in frames_of(fingers).jpegs(85).items()] == [("left", 0.5), ("right", 0.5)]
        states = fingers.process({"left": (*frame, 0.9), "right": (*frame, 1.0)})
        assert not states["right"].healthy and states["right"].stamp == 1.0
        assert "camera right" in states["right"].health_reason
        assert "raised ValueError: frame at 1 s has no markers" in states["right"].health_reason
        assert not fingers.processes["right"].is_alive()
        assert not fingers.process({"left": (*frame, 0.95), "right": (*frame, 1.1)})["right"].healthy
        assert list(fingers.frames.jpegs(85)) == ["left"]  # none from a failed worker
    finally:
        fingers.close()


def test_a_worker_that_stops_answering_a_jpeg_request_is_not_waited_for(monkeypatch):
    fingers = pixel_workers.FingerWorkers(_FailingFinger, {"left": "left", "right": "right"}, ("right",))
    try:
        frame = (np.zeros((1, 2)), np.ones(1), None, 0.0)
        assert fingers.process({f: (*frame, 0.5) for f in ("left", "right")})["right"].healthy
        monkeypatch.setattr(pixel_workers, "REPLY_TIMEOUT", 1.0)  # from now on: a busy machine may be slow before
        os.kill(fingers.processes["right"].pid, signal.SIGSTOP)
        started = time.monotonic()
        assert list(fingers.frames.jpegs(85)) == ["left"]
        assert time.monotonic() - started < 5.0
        state = fingers.process({f: (*frame, 0.6) for f in ("left", "right")})["right"]
        assert not state.healthy and "camera right" in state.health_reason
        assert "did not answer in 1 s" in state.health_reason and not fingers.processes["right"].is_alive()
    finally:
        fingers.close()


def test_a_worker_that_fails_to_start_fails_the_cell_build_with_the_cause():
    with pytest.raises(DriverFault, match="camera right.*raised RuntimeError: no camera model for 'broken'"):
        pixel_workers.FingerWorkers(_FailingFinger, {"left": "left", "right": "broken"}, ("right",))


def test_pixel_workers_must_be_a_boolean(tmp_path):
    with pytest.raises(CellFileError, match="pixel_workers.*true or false"):
        load_cell(_cell_file(tmp_path, "yes"), 30.0, "hold", perception="pixels")
