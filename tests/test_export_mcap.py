"""`fvtree export RUN_DIR` (assembly/interop/mcap/export.py): a run's MCAP file read back with the
`mcap` reader: topics, schema names, message counts, log times from the cell clock, and values
against the run's transition log, event log and summary; camera frames of a pixel-mode run; an old
run directory without a recording; and the errors for what is not a run."""

from __future__ import annotations

import base64
import json
import shutil
from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np
import pytest
from jsonschema import Draft202012Validator
from mcap.reader import make_reader

from assembly.cli import main
from assembly.observe.readback import read_recording
from assembly.run.options import RunOptions
from assembly.run.perception_stage import clear_blackboard
from assembly.run.session import run_tree

TREES = Path(__file__).resolve().parents[1] / "trees"
PERIOD_NS = 1e9 / 30  # the demo trees tick at 30 Hz
PER_TICK = {"/robot/pose": "foxglove.PoseInFrame", "/robot/wrench": "fvtree.Wrench", "/gripper": "fvtree.Gripper",
            "/fv/left/state": "fvtree.FingerState", "/fv/right/state": "fvtree.FingerState"}
SPARSE = {"/tree/status": "fvtree.NodeStatus", "/tree/transitions": "foxglove.Log", "/tree/feedback": "foxglove.Log",
          "/events": "foxglove.Log", "/task/element": "foxglove.Log", "/task/load_profile": "fvtree.LoadProfile",
          "/commands/arm": "foxglove.Log", "/commands/gripper": "foxglove.Log", "/cell/scene": "foxglove.SceneUpdate"}


def _run(tree: str, runs: Path, **options) -> Path:
    clear_blackboard()
    return Path(run_tree(str(TREES / tree), RunOptions(runs_dir=runs, plots=False, quiet=True, **options)).run_dir)


def _read(path: Path) -> tuple[dict, dict[str, list[tuple[int, dict]]]]:
    """(topic -> schema name, topic -> [(log time, message)]) of an MCAP file, checking the encodings
    and each message against its channel's JSON schema."""
    schemas, messages, validators = {}, defaultdict(list), {}
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
            assert (schema.encoding, channel.message_encoding) == ("jsonschema", "json")
            if schema.name not in validators:
                document = json.loads(schema.data)
                assert document["title"] == schema.name
                validators[schema.name] = Draft202012Validator(document)
            data = json.loads(message.data)
            validators[schema.name].validate(data)
            schemas[channel.topic] = schema.name
            messages[channel.topic].append((message.log_time, data))
    return schemas, dict(messages)


def _jsonl(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


@pytest.fixture(scope="module")
def assembly(tmp_path_factory) -> tuple[Path, dict, dict, dict]:
    """The simulated assembly cut short after placing E1 (113 s of cell time: E1 is placed at about 110 s), exported by the CLI:
    (run directory, summary, topic -> schema, topic -> messages)."""
    run_dir = _run("assembly.yaml", tmp_path_factory.mktemp("runs"), max_time=113.0)
    assert main(["export", str(run_dir)]) == 0
    return (run_dir, json.loads((run_dir / "summary.json").read_text()), *_read(run_dir / "recording.mcap"))


def test_topics_and_schemas(assembly):
    run_dir, _, schemas, _ = assembly
    assert schemas == {**PER_TICK, **SPARSE}
    assert sorted(p.name for p in run_dir.iterdir() if "mcap" in p.name) == ["recording.mcap"]  # no temp file left


def test_one_message_a_tick_with_cell_clock_log_times(assembly):
    _, summary, _, messages = assembly
    for topic in PER_TICK:
        ticks = [m.get("tick", round(t / PERIOD_NS)) for t, m in messages[topic]]  # PoseInFrame has no tick
        assert ticks == list(range(len(ticks))) and len(ticks) in (summary["ticks"], summary["ticks"] + 1), topic
        for t, m in messages[topic]:
            assert abs(t - round(t / PERIOD_NS) * PERIOD_NS) < 1e3  # a whole number of periods, to 1 us
            assert m["timestamp"]["sec"] * 10**9 + m["timestamp"]["nsec"] == t
    first = messages["/robot/pose"][0][1]["pose"]
    assert first["position"] == pytest.approx({"x": 0.0, "y": 0.0, "z": 0.5})  # the sim cell's home,
    assert first["orientation"] == pytest.approx({"x": 1.0, "y": 0.0, "z": 0.0, "w": 0.0}, abs=1e-6)  # tool down
    widths = [m["width"] for _, m in messages["/gripper"]]
    assert min(widths) < widths[0] == max(widths)  # E1 was gripped, from the open gripper
    assert {m["object"]["present"] for _, m in messages["/fv/left/state"]} == {False, True}  # and felt by the skin


def test_node_statuses_match_the_transition_log(assembly):
    run_dir, _, _, messages = assembly
    transitions = _jsonl(run_dir / "transitions.jsonl")
    statuses = messages["/tree/status"]
    assert len(statuses) == len(transitions) == len(messages["/tree/transitions"])
    for (t, m), record in zip(statuses, transitions):
        assert (m["tick"], m["node"], m["status"]) == (record["tick"], record["node"], record["to"])
        assert t == pytest.approx(record["t"] * 1e9, abs=1e3)
    last = {}
    for record in transitions:
        last[record["node"]] = record["to"]
    assert statuses[-1][1]["tree"] == last  # every node's status at the last tick
    assert statuses[-1][1]["tree"]["main/assemble/elements/build/prop/place"] == "INVALID"  # halted by the timeout


def test_events_and_load_profile_match_the_logs(assembly):
    run_dir, summary, _, messages = assembly
    logged = _jsonl(run_dir / "events.jsonl")
    events = [m for _, m in messages["/events"]]
    assert [m["message"].split()[0] for m in events] == [e["event"] for e in logged] == [
        "start", "placing", "placed", "halted", "end"]
    assert [m["level"] for m in events] == [2, 2, 2, 3, 3]  # INFO, and WARNING for the halt and a TIMEOUT's end
    [(_, profile)] = messages["/task/load_profile"]
    element = summary["elements"]["E1"]
    assert profile["element"] == "E1"
    assert profile["best_position"] == pytest.approx(element["position"], abs=1e-6)
    assert profile["best_load"] == pytest.approx(element["measured_load_px"])
    assert len(profile["position"]) == len(profile["load"]) == len(profile["smoothed"]) > 100
    best = int(np.argmin(np.abs(np.array(profile["position"]) - profile["best_position"])))
    assert profile["smoothed"][best] == pytest.approx(profile["best_load"], rel=0.01)


@pytest.fixture(scope="module")
def pixel_run(tmp_path_factory) -> Path:
    """A 2 s pixel-mode run of the hold demo, recording camera frames at 5 Hz."""
    return _run("hold.yaml", tmp_path_factory.mktemp("runs"), perception="pixels", max_time=2.0, record_images=5.0)


def test_camera_frames_of_a_pixel_run(pixel_run, tmp_path):
    run_dir = pixel_run
    out = tmp_path / "hold.mcap"
    assert main(["export", str(run_dir), "--out", str(out), "--format", "mcap"]) == 0
    schemas, messages = _read(out)
    recorded = read_recording(run_dir / "recording.rrd")
    for finger in ("left", "right"):
        frames = messages[f"/fv/{finger}/image"]
        assert schemas[f"/fv/{finger}/image"] == "foxglove.CompressedImage"
        ticks = [round(t / PERIOD_NS) for t, _ in frames]
        assert ticks == [r["tick"] for r in recorded[f"fv/{finger}/markers/image"]]
        assert ticks[:10] == list(range(0, 60, 6))  # 5 frames a second of cell time
        image = frames[-1][1]
        assert (image["format"], image["frame_id"]) == ("jpeg", f"fv_{finger}")
        decoded = cv2.imdecode(np.frombuffer(base64.b64decode(image["data"]), np.uint8), cv2.IMREAD_COLOR)
        assert decoded.shape == (240, 320, 3) and decoded.std() > 5  # a rendered skin, not a blank


def test_an_old_run_without_a_recording_exports_its_logs(assembly, tmp_path):
    run_dir = tmp_path / "old"
    shutil.copytree(assembly[0], run_dir, ignore=shutil.ignore_patterns("recording*"))
    assert main(["export", str(run_dir)]) == 0
    schemas, messages = _read(run_dir / "recording.mcap")
    assert set(schemas) == {"/tree/status", "/tree/transitions", "/events"}
    assert [m["tree"] for _, m in messages["/tree/status"]][-1] == assembly[3]["/tree/status"][-1][1]["tree"]


def test_a_resumed_runs_sessions_follow_one_another(pixel_run, tmp_path):
    run_dir = tmp_path / "resumed"
    shutil.copytree(pixel_run, run_dir)
    assert main(["export", str(run_dir), "--out", str(tmp_path / "once.mcap")]) == 0
    _, single = _read(tmp_path / "once.mcap")
    shutil.copy(run_dir / "recording.rrd", run_dir / "recording-2.rrd")  # a second session, as `--resume` names it
    assert main(["export", str(run_dir)]) == 0
    _, messages = _read(run_dir / "recording.mcap")
    once = single["/robot/pose"]
    poses = messages["/robot/pose"]
    assert len(poses) == 2 * len(once)
    times = [t for t, _ in poses]
    assert times == sorted(times) and times[len(once)] == once[-1][0] + 1  # the second session starts after the first
    ticks = [m["tick"] for _, m in single["/fv/left/state"]]
    assert [m["tick"] for _, m in messages["/fv/left/state"]] == ticks * 2  # each session keeps its own ticks


def test_the_3d_scene_shows_plates_and_the_placed_element(assembly):
    _, summary, _, messages = assembly
    entities = defaultdict(list)
    for t, update in messages["/cell/scene"]:
        [entity] = update["entities"]
        entities[entity["id"]].append((t, entity))
    [(t, plates)] = entities["plates"]
    assert t == 0 and [text["text"] for text in plates["texts"]] == ["P1", "P2"] and len(plates["cubes"]) == 2
    assert set(entities) == {"plates", "elements/E1", "elements/E2"}
    [cube] = entities["elements/E1"][-1][1]["cubes"]
    assert cube["color"] == pytest.approx({"r": 60 / 255, "g": 180 / 255, "b": 75 / 255, "a": 1.0})  # placed
    x, y, z = summary["elements"]["E1"]["asbuilt_pose"][:3]
    assert cube["pose"]["position"] == pytest.approx({"x": x, "y": y, "z": z}, abs=1e-6)
    assert [e["cubes"][0]["color"]["a"] for _, e in entities["elements/E2"]] == [pytest.approx(90 / 255)]  # planned


@pytest.mark.parametrize("case", ["missing", "not a run", "garbage recording", "no output directory"])
def test_errors_name_the_path_and_exit_2(case, tmp_path, capsys):
    run_dir, out = tmp_path / "run", []
    if case != "missing":
        run_dir.mkdir()
    if case == "garbage recording":
        (run_dir / "recording.rrd").write_text("not a recording\n")
    if case == "no output directory":
        (run_dir / "transitions.jsonl").write_text("")
        out = ["--out", str(tmp_path / "nowhere" / "x.mcap")]
    assert main(["export", str(run_dir), *out]) == 2
    err = capsys.readouterr().err
    expected = {"missing": "no such run directory", "not a run": "not a run directory",
                "garbage recording": "not a readable recording", "no output directory": "--out: no such directory"}
    assert str(tmp_path) in err and expected[case] in err
    assert not list(tmp_path.rglob("*.mcap*"))
