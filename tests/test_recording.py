"""Run recordings (assembly/observe/recorder.py) read back: what entities they hold, how many rows,
the values at given ticks against the run's transition log and event log, a killed run's
recording, and `--no-record`."""

from __future__ import annotations

import itertools
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from assembly.observe.readback import read_recording
from assembly.observe.scene3d import ELEMENT_COLOURS
from assembly.observe.tree_graph import STATUS_COLOURS
from assembly.run.options import RunOptions
from assembly.run.session import run_tree

ROOT = Path(__file__).resolve().parents[1]
ASSEMBLY = ROOT / "trees" / "assembly.yaml"
FINGER_ENTITIES = ("markers", "force", "torque", "slip", "object", "health")


@pytest.fixture(scope="module")
def assembly_run(tmp_path_factory) -> tuple[dict, Path, dict]:
    """One recorded simulated assembly: (summary, run directory, recording read back)."""
    from assembly.run.perception_stage import clear_blackboard

    clear_blackboard()
    summary = run_tree(str(ASSEMBLY), RunOptions(runs_dir=tmp_path_factory.mktemp("runs"), plots=False, quiet=True))
    run_dir = Path(summary.run_dir)
    return summary, run_dir, read_recording(run_dir / "recording.rrd")


def _jsonl(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _statuses_until(rows: list[dict], tick: int) -> dict[str, str]:
    """Each node's last status at or before `tick`, from `tree/status` rows of a recording."""
    statuses = {}
    for row in rows:
        if row["tick"] is not None and row["tick"] <= tick:
            statuses[row["node"][0]] = row["status"][0]
    return statuses


def test_every_kind_of_data_is_recorded(assembly_run):
    _, _, rec = assembly_run
    expected = {"tree/graph", "tree/status", "tree/transitions", "robot/pose", "robot/wrench", "gripper/width",
                "gripper/object", "cell/tool", "cell/plates", "commands/arm", "commands/gripper", "events",
                "task/element", "info"}
    expected |= {f"fv/{finger}/{what}" for finger in ("left", "right") for what in FINGER_ENTITIES}
    assert expected <= set(rec)
    assert any(e.startswith("task/load_profile/") for e in rec)
    assert {"cell/elements/E1", "cell/elements/E2"} <= set(rec)
    placed = [r for r in rec["cell/elements/E1"] if r["tick"] is not None]
    assert len(placed) >= 3 and all(r["tick"] is not None for r in rec["cell/elements/E1"])  # planned, placing, placed
    assert placed[-1]["Boxes3D:colors"] == [_rgba(ELEMENT_COLOURS["placed"])]


def test_one_row_per_tick_on_both_timelines(assembly_run):
    summary, _, rec = assembly_run
    ticks = summary.ticks
    for entity in ("robot/pose", "fv/left/force", "fv/right/markers", "cell/tool"):
        rows = [r for r in rec[entity] if r["tick"] is not None and "Scalars:scalars" in r
                or "Arrows2D:vectors" in r and r["Arrows2D:vectors"] is not None
                or "Transform3D:translation" in r]
        assert [r["tick"] for r in rows] == list(range(ticks)), entity
        assert rows[-1]["cell_time"] == pytest.approx((ticks - 1) / 30.0)


def test_values_at_given_ticks(assembly_run):
    _, _, rec = assembly_run
    poses = {r["tick"]: r["Scalars:scalars"] for r in rec["robot/pose"] if r["tick"] is not None}
    assert poses[0] == pytest.approx([0.0, 0.0, 0.5, np.pi, 0.0, 0.0])  # the sim cell's home
    widths = [r["Scalars:scalars"][0] for r in rec["gripper/width"] if r["tick"] is not None]
    assert 0.0 < min(widths) < max(widths) <= 0.085
    arrows = [r for r in rec["fv/left/markers"] if r.get("Arrows2D:vectors")]
    origins = next(r["Arrows2D:origins"] for r in rec["fv/left/markers"] if r.get("Arrows2D:origins"))
    assert len(arrows[0]["Arrows2D:vectors"]) == len(arrows[0]["Arrows2D:colors"]) == len(origins) > 10
    tracked = np.uint32(0x3CB44BFF)  # the recorder's colour of a tracked marker
    assert arrows[0]["Arrows2D:colors"].count(tracked) >= 0.8 * len(origins)  # tracked before any contact


def test_node_statuses_at_the_first_placement_match_the_transition_log(assembly_run):
    _, run_dir, rec = assembly_run
    placed = [r for r in rec["events"] if r["tick"] is not None and r["TextLog:text"][0].startswith("placed ")]
    assert placed, "no placement recorded"
    tick = placed[0]["tick"]
    logged = {}
    for record in _jsonl(run_dir / "transitions.jsonl"):
        if record["tick"] <= tick:
            logged[record["node"]] = record["to"]
    recorded = _statuses_until(rec["tree/status"], tick)
    assert recorded == logged
    assert recorded["main/assemble/elements/build/prop/place"] == "RUNNING"
    # The graph's colours at that tick say the same; none are static (a static value hides all later ones).
    assert not any("GraphNodes:colors" in r for r in rec["tree/graph"] if r["tick"] is None)
    graph = [r for r in rec["tree/graph"] if r["tick"] is not None and r["tick"] <= tick][-1]
    paths = next(r["GraphNodes:node_ids"] for r in rec["tree/graph"] if r["tick"] is None and r.get("GraphNodes:node_ids"))
    colour_of = {_rgba(v): name for name, v in STATUS_COLOURS.items()}
    by_colour = {path: colour_of[c] for path, c in zip(paths, graph["GraphNodes:colors"])}
    assert {p: s for p, s in by_colour.items() if s != "INVALID"} == {p: s for p, s in logged.items() if s != "INVALID"}


def _rgba(colour: tuple[int, int, int, int]) -> int:
    r, g, b, a = colour
    return (r << 24) | (g << 16) | (b << 8) | a


def test_every_transition_and_placement_is_recorded(assembly_run):
    _, run_dir, rec = assembly_run
    transitions = _jsonl(run_dir / "transitions.jsonl")
    rows = [r for r in rec["tree/status"] if r["tick"] is not None]
    assert [(r["tick"], r["node"][0], r["status"][0], r["feedback"][0]) for r in rows] == \
           [(t["tick"], t["node"], t["to"], t["feedback"]) for t in transitions]
    events = [e["event"] for e in _jsonl(run_dir / "events.jsonl")]
    recorded = [r["TextLog:text"][0].split()[0] for r in rec["events"] if r["tick"] is not None]
    assert recorded == events[:len(recorded)] and recorded.count("placed") == events.count("placed") == 2


def test_commands_are_tapped_at_the_safety_gate(assembly_run):
    _, _, rec = assembly_run
    arm = [r["TextLog:text"][0] for r in rec["commands/arm"] if r["tick"] is not None]
    gripper = [r["TextLog:text"][0] for r in rec["commands/gripper"] if r["tick"] is not None]
    assert arm and all(t.split()[0] in ("move_linear", "speed_linear", "stop") for t in arm)
    assert any(t.startswith("move_linear [") for t in arm)
    assert gripper and all(t.startswith(("gripper move ", "stop")) for t in gripper)
    # Each command is stamped with the tick that sent it: spread over the run, not piled on tick 0.
    ticks = [r["tick"] for r in rec["commands/arm"] + rec["commands/gripper"] if r["tick"] is not None]
    assert ticks.count(0) <= 2 and len(set(ticks)) > len(ticks) / 4


@pytest.mark.slow
def test_a_killed_run_keeps_a_readable_recording(tmp_path):
    """SIGKILL mid-run (no handler runs): the recording holds every batch sent before it."""
    runs = tmp_path / "runs"
    process = subprocess.Popen([sys.executable, "-m", "assembly.cli", "run", str(ASSEMBLY), "--runs-dir", str(runs),
                                "--no-plots"], cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            files = list(runs.glob("*/recording.rrd"))
            if files and files[0].stat().st_size > 300_000:
                break
            assert process.poll() is None, "the run ended before it could be killed"
            time.sleep(0.05)
        else:
            pytest.fail("the recording did not grow within 300 s")
        os.kill(process.pid, signal.SIGKILL)
    finally:
        process.wait(timeout=60)
    rec = read_recording(files[0])
    ticks = [r["tick"] for r in rec["robot/pose"] if r["tick"] is not None]
    assert len(ticks) >= 150 and ticks == list(range(len(ticks)))
    assert rec["tree/status"][0]["node"] == ["main/estop"]


def test_no_record_writes_no_recording(tmp_path):
    summary = run_tree(str(ASSEMBLY), RunOptions(runs_dir=tmp_path, plots=False, quiet=True, record=False, max_time=1.0))
    assert not list(Path(summary.run_dir).glob("*.rrd"))


def test_the_load_profile_grows_during_the_scan(assembly_run):
    _, _, rec = assembly_run
    rows = [r for r in rec["task/load_profile/E1/load"] if r["tick"] is not None]
    lengths = [len(r["LineStrips2D:strips"][0]) for r in rows]
    assert len(rows) >= 10  # drawn about once a second of cell time while the scan goes
    assert lengths == sorted(lengths) and lengths[0] < lengths[-1] / 5
    final = [r["tick"] for r in rec["task/load_profile/E1/best"] if r["tick"] is not None]
    assert len(final) == 1 and rows[-1]["tick"] == final[0]  # the whole profile, with its chosen point, last
    growing = [r["tick"] for r in rows[:-1]]
    assert all(b - a >= 29 for a, b in itertools.pairwise(growing))


def test_the_end_of_the_run_is_recorded(assembly_run):
    """The `end` event (status after the scene's verdict, where, message), after the last tick, as in the event log."""
    summary, run_dir, rec = assembly_run
    last = rec["events"][-1]
    assert last["tick"] == summary.ticks and last["TextLog:level"] == ["INFO"]
    kind, details = last["TextLog:text"][0].split(" ", 1)
    logged = _jsonl(run_dir / "events.jsonl")[-1]
    assert kind == logged["event"] == "end"
    assert json.loads(details) == {k: v for k, v in logged.items() if k not in ("time", "event")}
    assert json.loads(details)["status"] == summary.status == "SUCCESS"


def test_a_run_without_a_design_records_its_end(tmp_path):
    """A tree with no design: the recorder reads the halt and the end from its event log, as it
    does a design run's (before, such a run had no event log and the session told the recorder)."""
    summary = run_tree(str(ROOT / "trees" / "hold.yaml"), RunOptions(runs_dir=tmp_path, plots=False, quiet=True, max_time=1.0))
    rec = read_recording(Path(summary.run_dir) / "recording.rrd", ["events"])
    kinds = [r["TextLog:text"][0].split()[0] for r in rec["events"]]
    assert kinds[-2:] == ["halted", "end"]  # stopped by max_time: the halt, then the end after the halt's tick
    halt, end = rec["events"][-2:]
    assert end["tick"] == halt["tick"] + 1 >= summary.ticks and end["TextLog:level"] == ["WARN"]
    assert json.loads(end["TextLog:text"][0].split(" ", 1)[1])["status"] == summary.status == "TIMEOUT"


def test_reading_only_some_entities(assembly_run):
    _, run_dir, rec = assembly_run
    wanted = ["tree/status", "/events", "fv/left/force"]
    some = read_recording(run_dir / "recording.rrd", wanted)
    assert some == {e: rec[e] for e in ("tree/status", "events", "fv/left/force")}
    assert read_recording(run_dir / "recording.rrd", []) == {}


def test_batch_columns_give_the_per_tick_arrows_and_end_at_a_calibration():
    """Each tick's displacement arrows and validity (a field without flags: all tracked); a tick with a
    new calibration, or one past the batch's capacity, starts the next batch."""
    from assembly.observe.columns import TickColumns
    from perception.state import MarkerField, TactileState

    rng = np.random.default_rng(0)
    first, second = rng.random((4, 2)) * 100, rng.random((4, 2)) * 100
    fields = [MarkerField(first, first + rng.normal(0, 1, (4, 2)), np.ones(4), np.ones(4), valid)
              for valid in (np.array([True, False, True, True]), np.zeros(0, bool))]
    states = [(TactileState("left", 0.0, f), TactileState("right", 0.0, f)) for f in fields]
    columns = TickColumns(2, states[0])
    for tick, pair in enumerate(states):
        assert columns.takes(pair)
        columns.add(tick, tick / 30.0, np.arange(6.0), np.zeros(6), 0.04, True, pair)
    arrows, valid = columns.arrows(1)
    for i, f in enumerate(fields):
        assert np.array_equal(arrows[i], f.position - f.origin)
    assert valid.tolist() == [[True, False, True, True], [True] * 4]
    assert columns.finger_table(0, valid)[:, 12].tolist() == [0.75, 1.0]  # the share of valid markers
    assert columns.robot_table()[:, 13].tolist() == [1.0, 1.0] and not columns.takes(states[0])  # full
    calibrated = TactileState("left", 0.0, MarkerField(second, second, np.ones(4), np.ones(4)))
    assert not TickColumns(5, states[0]).takes((calibrated, states[0][1]))


def test_batch_columns_read_views_and_lists_as_whole_arrays():
    """Marker positions that are views into a wider array (x, y, size per marker, as the noisy simulated
    fingertip makes them) and a pose given as a list give the same columns as whole arrays do."""
    from assembly.observe.columns import TickColumns
    from perception.state import MarkerField, TactileState

    rng = np.random.default_rng(1)
    origin = rng.random((4, 2)) * 100
    markers = [rng.random((4, 3)) * 100 for _ in range(2)]  # x, y, size
    tables = []
    for view in (True, False):
        states = [tuple(TactileState(finger, 0.0, MarkerField(origin, m[:, :2] if view else m[:, :2].copy()))
                        for finger in ("left", "right")) for m in markers]
        columns = TickColumns(2, states[0])
        for tick, pair in enumerate(states):
            pose = [float(tick)] * 6 if view else np.full(6, float(tick))
            columns.add(tick, tick / 30.0, pose, np.zeros(6), 0.04, False, pair)
        arrows, valid = columns.arrows(0)
        tables.append((arrows, columns.finger_table(0, valid), columns.robot_table()))
    for views, whole in zip(*tables):
        assert np.array_equal(views, whole)
    assert np.array_equal(tables[0][0][1], markers[1][:, :2] - origin)


def test_batch_columns_of_mixed_number_types_keep_their_values():
    """A column whose arrays are not all floats (a driver giving an integer pose on one tick) keeps its
    numbers: the bytes of arrays of another type are never read as floats."""
    from assembly.observe.columns import TickColumns
    from perception.state import TactileState

    pair = (TactileState("left", 0.0), TactileState("right", 0.0))
    columns = TickColumns(3, pair)
    poses = [np.full(6, 1.5), np.arange(6), np.full(6, 2.5)]  # the second one int64, eight bytes as a float
    for tick, pose in enumerate(poses):
        columns.add(tick, tick / 30.0, pose, np.zeros(6), 0.04, False, pair)
    assert np.array_equal(columns.robot_table()[:, :6], np.array(poses, float))


def test_a_recording_cut_inside_a_message_reads_up_to_it(assembly_run, tmp_path):
    """SIGKILL while a batch is written leaves its message cut: the whole messages before it are read."""
    _, run_dir, rec = assembly_run
    data = (run_dir / "recording.rrd").read_bytes()
    cut = tmp_path / "cut.rrd"
    cut.write_bytes(data[:len(data) // 2])
    poses = [r["tick"] for r in read_recording(cut, ["robot/pose"])["robot/pose"] if r["tick"] is not None]
    assert 0 < len(poses) < len(rec["robot/pose"]) - 1 and poses == list(range(len(poses)))


def test_rows_added_from_another_thread_never_unbalance_a_batch():
    """The safety layer's watchdog stops the arm from its own thread, and its commands reach the
    recorder while the tick thread sends a batch: every batch taken has as many times as values,
    and no row is lost (before: 198 texts for 197 times once in CI, and Rerun dropped that batch)."""
    import threading

    from assembly.observe.columns import Sparse

    sparse, rows = Sparse(), 20000
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # switch threads as often as the interpreter can: the race shows at once

    def add() -> None:
        for k in range(rows):
            sparse.add(k, k * 0.002, ("speed_linear", ()))

    adder = threading.Thread(target=add)
    adder.start()
    taken_rows = 0
    try:
        while adder.is_alive() or taken_rows < rows:
            taken = sparse.take()
            if taken:
                index, values = taken
                assert [len(c.as_arrow_array()) for c in index] == [len(values)] * 2
                taken_rows += len(values)
    finally:
        adder.join()
        sys.setswitchinterval(switch)
    assert taken_rows == rows
