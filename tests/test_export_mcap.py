"""`fvtree export RUN_DIR` (assembly/interop/mcap/export.py): a run's MCAP file read back with the
`mcap` reader: topics, schema names, message counts, log times on the wall clock (the run's start
event plus cell time), and values
against the run's transition log, event log and summary; camera frames of a pixel-mode run; an old
run directory without a recording; and the errors for what is not a run."""

from __future__ import annotations

import base64
import json
import shutil
import subprocess
import tarfile
from collections import defaultdict
from itertools import pairwise
from pathlib import Path

import cv2
import numpy as np
import pytest
from jsonschema import Draft202012Validator
from mcap.reader import make_reader

from assembly.cli import main
from assembly.interop.mcap.schemas import SCHEMAS
from assembly.observe.readback import read_recording
from assembly.run.options import RunOptions
from assembly.run.perception_stage import clear_blackboard
from assembly.run.session import run_tree

TREES = Path(__file__).resolve().parents[1] / "trees"
OFFICIAL_SCHEMAS = "@foxglove/schemas@2"  # Foxglove's JSON schemas, on the npm registry
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


def _start(run_dir: Path) -> int:
    """The wall-clock ns of the run's cell time 0: its `start` event (every run logs one, the hold
    demo's without a design too), a little after the recording's own start time."""
    [start] = [e["time"] for e in _jsonl(run_dir / "events.jsonl") if e["event"] == "start"]
    [row] = read_recording(run_dir / "recording.rrd", ["__properties"])["__properties"]
    assert 0 <= round(start * 1e9) - row["RecordingInfo:start_time"][0] < 60e9
    return round(start * 1e9)


@pytest.fixture(scope="module")
def assembly(tmp_path_factory) -> tuple[Path, dict, dict, dict]:
    """The simulated assembly cut short after placing E1 (127 s of cell time: E1 is placed at about 125.6 s), exported by the CLI:
    (run directory, summary, topic -> schema, topic -> messages)."""
    run_dir = _run("assembly.yaml", tmp_path_factory.mktemp("runs"), max_time=127.0)
    assert main(["export", str(run_dir)]) == 0
    return (run_dir, json.loads((run_dir / "summary.json").read_text()), *_read(run_dir / "recording.mcap"))


def test_topics_and_schemas(assembly):
    run_dir, _, schemas, _ = assembly
    assert schemas == {**PER_TICK, **SPARSE}
    assert sorted(p.name for p in run_dir.iterdir() if "mcap" in p.name) == ["recording.mcap"]  # no temp file left


def test_one_message_a_tick_with_wall_clock_log_times(assembly):
    run_dir, summary, _, messages = assembly
    start = _start(run_dir)
    assert start > 1.7e18  # 2023 or later, not 1970
    for topic in PER_TICK:
        ticks = [m.get("tick", round((t - start) / PERIOD_NS)) for t, m in messages[topic]]  # PoseInFrame: no tick
        assert ticks == list(range(len(ticks))) and len(ticks) in (summary["ticks"], summary["ticks"] + 1), topic
        for (t, m), tick in zip(messages[topic], ticks):
            assert abs(t - start - tick * PERIOD_NS) < 1e3  # the start plus a whole number of periods, to 1 us
            assert m["timestamp"]["sec"] * 10**9 + m["timestamp"]["nsec"] == t
    first = messages["/robot/pose"][0][1]["pose"]
    assert first["position"] == pytest.approx({"x": 0.0, "y": 0.0, "z": 0.5})  # the sim cell's home,
    assert first["orientation"] == pytest.approx({"x": 1.0, "y": 0.0, "z": 0.0, "w": 0.0}, abs=1e-6)  # tool down
    widths = [m["width"] for _, m in messages["/gripper"]]
    assert min(widths) < widths[0] == max(widths)  # E1 was gripped, from the open gripper
    assert {m["object"]["present"] for _, m in messages["/fv/left/state"]} == {False, True}  # and felt by the skin


def test_node_statuses_match_the_transition_log(assembly):
    run_dir, _, _, messages = assembly
    start = _start(run_dir)
    transitions = _jsonl(run_dir / "transitions.jsonl")
    statuses = messages["/tree/status"]
    assert len(statuses) == len(transitions) == len(messages["/tree/transitions"])
    for (t, m), record in zip(statuses, transitions):
        assert (m["tick"], m["node"], m["status"]) == (record["tick"], record["node"], record["to"])
        assert t - start == pytest.approx(record["t"] * 1e9, abs=1e3)
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


def test_camera_frames_of_a_pixel_run(pixel_run, tmp_path, request):
    run_dir = pixel_run
    out = tmp_path / "hold.mcap"
    assert main(["export", str(run_dir), "--out", str(out), "--format", "mcap"]) == 0
    schemas, messages = _read(out)
    recorded = read_recording(run_dir / "recording.rrd")
    for finger in ("left", "right"):
        frames = messages[f"/fv/{finger}/image"]
        assert schemas[f"/fv/{finger}/image"] == "foxglove.CompressedImage"
        ticks = [round((t - _start(run_dir)) / PERIOD_NS) for t, _ in frames]
        assert ticks == [r["tick"] for r in recorded[f"fv/{finger}/markers/image"]]
        assert ticks[:10] == list(range(0, 60, 6))  # 5 frames a second of cell time
        image = frames[-1][1]
        assert (image["format"], image["frame_id"]) == ("jpeg", f"fv_{finger}")
        decoded = cv2.imdecode(np.frombuffer(base64.b64decode(image["data"]), np.uint8), cv2.IMREAD_COLOR)
        assert decoded.shape == (240, 320, 3) and decoded.std() > 5  # a rendered skin, not a blank
    if shutil.which("npm"):  # the images against Foxglove's official schema too (test_foxglove_schemas_...)
        official = request.getfixturevalue("official_schemas")["foxglove.CompressedImage"]
        for finger in ("left", "right"):
            for _, image in messages[f"/fv/{finger}/image"]:
                Draft202012Validator(official).validate(image)


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
    run_dir, summary, _, messages = assembly
    entities = defaultdict(list)
    for t, update in messages["/cell/scene"]:
        [entity] = update["entities"]
        entities[entity["id"]].append((t, entity))
    [(t, plates)] = entities["plates"]
    assert t == _start(run_dir) and [text["text"] for text in plates["texts"]] == ["P1", "P2"] and len(plates["cubes"]) == 2
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


@pytest.fixture(scope="module")
def official_schemas(tmp_path_factory) -> dict[str, dict]:
    """Foxglove's official JSON schemas by title, from the `@foxglove/schemas` package of the npm
    registry (its `dist/jsonschema`, read with node)."""
    npm, node = shutil.which("npm"), shutil.which("node")
    if not (npm and node):
        pytest.skip("needs npm and node (Debian's nodejs and npm) to fetch Foxglove's official @foxglove/schemas")
    tmp = tmp_path_factory.mktemp("foxglove")
    packed = subprocess.run([npm, "pack", OFFICIAL_SCHEMAS, "--pack-destination", str(tmp)], check=False,
                            capture_output=True, text=True, timeout=600)
    if packed.returncode:
        pytest.skip(f"npm could not fetch {OFFICIAL_SCHEMAS}: {packed.stderr.strip()[-300:]}")
    [archive] = tmp.glob("*.tgz")
    with tarfile.open(archive) as tar:
        tar.extractall(tmp, filter="data")
    dumped = subprocess.run([node, "-e", "process.stdout.write(JSON.stringify(require(process.argv[1])))",
                             str(tmp / "package" / "dist" / "jsonschema" / "index.js")],
                            capture_output=True, text=True, timeout=120, check=True)
    return {schema["title"]: schema for schema in json.loads(dumped.stdout).values()}


def _same_shape(ours: dict, official: dict, where: str) -> None:
    """`ours` says what `official` says (titles, types, bounds, properties in order, `required`), leaving
    out descriptions; an array whose items `ours` leaves open is one the export leaves empty."""
    for key, value in ours.items():
        if key not in ("description", "properties", "items", "oneOf"):
            assert official.get(key) == value, f"{where}: {key}"
    if "properties" in ours:
        assert list(ours["properties"]) == list(official["properties"]), where
        assert ours.get("required") == official.get("required"), f"{where}: required"
        for name, schema in ours["properties"].items():
            _same_shape(schema, official["properties"][name], f"{where}.{name}")
    if "items" in ours:
        _same_shape(ours["items"], official["items"], f"{where}[]")
    if "oneOf" in ours:
        assert [(o["title"], o["const"]) for o in ours["oneOf"]] == [(o["title"], o["const"]) for o in official["oneOf"]]


def test_foxglove_schemas_are_the_official_ones(assembly, official_schemas):
    _, _, schemas, messages = assembly
    for name, schema in SCHEMAS.items():
        if name.startswith("foxglove."):
            _same_shape(schema, official_schemas[name], name)
            assert official_schemas[name]["required"]  # (the official lists are there to compare with)
    validators = {name: Draft202012Validator(official_schemas[name]) for name in set(schemas.values())
                  if name.startswith("foxglove.")}
    assert set(validators) == {"foxglove.Log", "foxglove.PoseInFrame", "foxglove.SceneUpdate"}
    for topic, name in schemas.items():
        if name in validators:
            for _, message in messages[topic]:
                validators[name].validate(message)


# ---- ROS 2: `fvtree export RUN_DIR --ros2`, decoded by mcap-ros2-support (its own message-definition
# parser and CDR decoder; the export serialises with rosbags) ------------------------------------------
ROS2_TOPICS = {"/robot/pose": "geometry_msgs/msg/PoseStamped", "/robot/wrench": "geometry_msgs/msg/WrenchStamped",
               "/gripper/joint_states": "sensor_msgs/msg/JointState", "/cell/time": "sensor_msgs/msg/TimeReference",
               "/fv/left/wrench": "geometry_msgs/msg/WrenchStamped",
               "/fv/right/wrench": "geometry_msgs/msg/WrenchStamped",
               "/tree/status": "diagnostic_msgs/msg/DiagnosticArray", "/rosout": "rcl_interfaces/msg/Log"}


def _read_ros2(path: Path) -> tuple[dict, dict[str, list[tuple[int, object]]]]:
    """(topic -> message type, topic -> [(log time, decoded message)]) of a ROS 2 MCAP file, checking
    the profile and encodings, and that publish time equals log time."""
    from mcap_ros2.decoder import DecoderFactory

    types, messages = {}, defaultdict(list)
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            assert (schema.encoding, channel.message_encoding) == ("ros2msg", "cdr")
            assert message.publish_time == message.log_time
            types[channel.topic] = schema.name
            messages[channel.topic].append((message.log_time, decoded))
    return types, dict(messages)


def _ns(stamp) -> int:
    return stamp.sec * 10**9 + stamp.nanosec


@pytest.fixture(scope="module")
def ros2_assembly(assembly) -> tuple[dict, dict]:
    """The assembly run exported with `--ros2` and decoded: (topic -> type, topic -> messages)."""
    run_dir = assembly[0]
    assert main(["export", str(run_dir), "--ros2"]) == 0
    return _read_ros2(run_dir / "recording.ros2.mcap")


def test_ros2_topics_counts_and_wall_clock_stamps(assembly, ros2_assembly):
    run_dir, summary, _, _ = assembly
    types, messages = ros2_assembly
    assert types == ROS2_TOPICS
    start = _start(run_dir)
    # the run's span: its start plus its cell time (a halted run's includes the arm braking to rest
    # after its last tick, the end event logged then; sim_time_s is rounded to 1 ms)
    end = start + round(max((summary["ticks"] + 1) * PERIOD_NS, (summary["sim_time_s"] + 0.001) * 1e9 + PERIOD_NS))
    for topic in ("/robot/pose", "/robot/wrench", "/gripper/joint_states", "/cell/time", "/fv/left/wrench",
                  "/fv/right/wrench"):
        assert len(messages[topic]) in (summary["ticks"], summary["ticks"] + 1), topic  # one a tick
        stamps = [_ns(m.header.stamp) for _, m in messages[topic]]
        assert stamps == [t for t, _ in messages[topic]]  # header stamp = log time
        assert stamps[0] == start and stamps[-1] <= end and all(b > a for a, b in pairwise(stamps)), topic
    for topic in ("/tree/status", "/rosout"):
        stamps = [_ns(m.header.stamp if topic == "/tree/status" else m.stamp) for _, m in messages[topic]]
        assert stamps == [t for t, _ in messages[topic]] == sorted(stamps)
        assert start <= stamps[0] and stamps[-1] <= end, topic
    for _, clock in messages["/cell/time"]:  # the cell clock beside the wall clock
        tick = int(clock.source.removeprefix("cell tick "))
        assert _ns(clock.header.stamp) - start == _ns(clock.time_ref) == pytest.approx(tick * PERIOD_NS, abs=1e3)


def test_ros2_values_equal_the_recording(assembly, ros2_assembly):
    run_dir = assembly[0]
    _, messages = ros2_assembly
    rec = read_recording(run_dir / "recording.rrd")
    tool = [r for r in rec["cell/tool"] if r["tick"] is not None]
    poses = [m.pose for _, m in messages["/robot/pose"]]
    assert len(poses) == len(tool)
    for pose, row in zip(poses, tool):
        p, q = pose.position, pose.orientation
        assert [p.x, p.y, p.z] == row["Transform3D:translation"][0]
        assert [q.x, q.y, q.z, q.w] == row["Transform3D:quaternion"][0]
    for topic, entity in (("/robot/wrench", "robot/wrench"), ("/fv/left/wrench", "fv/left/force"),
                          ("/fv/right/wrench", "fv/right/force")):
        rows = [r for r in rec[entity] if r["tick"] is not None]
        forces = [[w.force.x, w.force.y, w.force.z] for w in (m.wrench for _, m in messages[topic])]
        assert forces == [r["Scalars:scalars"][:3] for r in rows], topic
    torques = [r["Scalars:scalars"] for r in rec["fv/left/torque"] if r["tick"] is not None]
    assert [[m.wrench.torque.x, m.wrench.torque.y, m.wrench.torque.z] for _, m in messages["/fv/left/wrench"]] == torques
    assert {m.header.frame_id for _, m in messages["/fv/left/wrench"]} == {"fv_left"}
    widths = [m.position[0] for _, m in messages["/gripper/joint_states"]]
    assert widths == [r["Scalars:scalars"][0] for r in rec["gripper/width"] if r["tick"] is not None]
    assert min(widths) < widths[0] == max(widths)  # E1 gripped from the open gripper


def test_ros2_tree_statuses_hold_every_change_of_the_transition_log(assembly, ros2_assembly):
    run_dir = assembly[0]
    _, messages = ros2_assembly
    start = _start(run_dir)
    transitions = _jsonl(run_dir / "transitions.jsonl")
    changes = [(int({v.key: v.value for v in s.values}["tick"]), s.name, s.message, t)
               for t, array in messages["/tree/status"] for s in array.status]
    assert [(tick, node, to) for tick, node, to, _ in changes] == [(r["tick"], r["node"], r["to"])
                                                                  for r in transitions]
    assert len(messages["/tree/status"]) == len({r["tick"] for r in transitions})  # one array a tick with changes
    for (_, _, _, t), record in zip(changes, transitions):
        assert t - start == pytest.approx(record["t"] * 1e9, abs=1e3)
    levels = {(s.message, s.level) for _, array in messages["/tree/status"] for s in array.status}
    assert {level for status, level in levels if status == "FAILURE"} == {1}  # WARN
    assert {level for status, level in levels if status != "FAILURE"} == {0}  # OK


def test_ros2_log_holds_the_events_and_transitions(assembly, ros2_assembly):
    run_dir = assembly[0]
    _, messages = ros2_assembly
    logs = [m for _, m in messages["/rosout"]]
    events = [m for m in logs if m.name == "fvtree.events"]
    assert [m.msg.split()[0] for m in events] == [e["event"] for e in _jsonl(run_dir / "events.jsonl")]
    assert [m.level for m in events] == [20, 20, 20, 30, 30]  # INFO; WARN for the halt and a TIMEOUT's end
    assert len([m for m in logs if m.name == "fvtree.tree"]) == len(_jsonl(run_dir / "transitions.jsonl"))


def test_ros2_camera_frames_of_a_pixel_run(pixel_run, tmp_path):
    out = tmp_path / "hold.ros2.mcap"
    assert main(["export", str(pixel_run), "--ros2", "--out", str(out)]) == 0
    types, messages = _read_ros2(out)
    start = _start(pixel_run)
    recorded = read_recording(pixel_run / "recording.rrd")
    for finger in ("left", "right"):
        topic = f"/fv/{finger}/image/compressed"
        assert types[topic] == "sensor_msgs/msg/CompressedImage"
        frames = recorded[f"fv/{finger}/markers/image"]
        assert [round((_ns(m.header.stamp) - start) / PERIOD_NS) for _, m in messages[topic]] == [
            r["tick"] for r in frames]
        image = messages[topic][-1][1]
        assert (image.format, image.header.frame_id) == ("jpeg", f"fv_{finger}")
        assert bytes(image.data) == bytes(frames[-1]["EncodedImage:blob"][0])
        decoded = cv2.imdecode(np.frombuffer(bytes(image.data), np.uint8), cv2.IMREAD_COLOR)
        assert decoded.shape == (240, 320, 3) and decoded.std() > 5


def test_ros2_a_resumed_runs_sessions_follow_one_another(pixel_run, tmp_path):
    run_dir = tmp_path / "resumed"
    shutil.copytree(pixel_run, run_dir)
    shutil.copy(run_dir / "recording.rrd", run_dir / "recording-2.rrd")
    assert main(["export", str(run_dir), "--ros2"]) == 0
    _, messages = _read_ros2(run_dir / "recording.ros2.mcap")
    stamps = [_ns(m.header.stamp) for _, m in messages["/robot/pose"]]
    half = len(stamps) // 2
    assert stamps == sorted(stamps) and stamps[half] == stamps[half - 1] + 1  # the copy starts as the first ends
    refs = [_ns(m.time_ref) for _, m in messages["/cell/time"]]
    assert refs[:half] == refs[half:] and refs[half] == 0  # each session's cell clock starts at 0


def test_ros2_bag_opens_in_rosbags_with_the_files_own_definitions(assembly, ros2_assembly):
    """rosbags (the library that wrote it) opens the file as a ROS 2 bag with an empty type store,
    so every type comes from the definitions in the file, and reads back every message."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    types, messages = ros2_assembly
    with AnyReader([assembly[0] / "recording.ros2.mcap"], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        assert reader.is2
        assert {c.topic: c.msgtype for c in reader.connections} == types
        assert {c.topic: c.msgcount for c in reader.connections} == {t: len(m) for t, m in messages.items()}
        read = defaultdict(list)
        for connection, t, raw in reader.messages():
            read[connection.topic].append((t, reader.deserialize(raw, connection.msgtype)))
    assert {topic: [t for t, _ in m] for topic, m in read.items()} == {
        topic: [t for t, _ in m] for topic, m in messages.items()}
    assert [s.name for s in read["/tree/status"][-1][1].status] == [
        s.name for s in messages["/tree/status"][-1][1].status]


def test_ros2_of_a_tree_is_refused(tmp_path, capsys):
    assert main(["export", str(TREES / "hold.yaml"), "--ros2"]) == 2
    assert "--ros2" in capsys.readouterr().err
