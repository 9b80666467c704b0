"""`fvtree export RUN_DIR`: a run as an MCAP file for Foxglove and ROS 2 tools (JSON messages with
JSON schemas, log times from the cell clock), read from the run's Rerun recordings through
`readback` (an old run directory without one: the recording `replay` builds from its logs).

Topics (schemas in `mcap_schemas`): `/tree/status` (on change), `/tree/transitions`, `/tree/feedback`,
`/events`, `/task/element`, `/commands/arm`, `/commands/gripper` (Log panel), `/task/load_profile`,
`/robot/pose` (the tool), `/robot/wrench`, `/gripper`, `/cell/scene` (plates and elements as 3-D
boxes coloured by status), and per finger `/fv/<finger>/state` and `/fv/<finger>/image` (the JPEG
camera frames, when the run recorded them). A resumed run's sessions
follow one another on the log-time axis (each session's cell clock starts again at 0)."""

from __future__ import annotations

import base64
import json
import os
import re
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from mcap.writer import Writer

from assembly.interop.mcap.schemas import SCHEMAS
from assembly.observe.readback import read_recording
from assembly.observe.recorder import PROFILE_HEIGHT
from assembly.observe.replay import run_recordings
from fvfiles.errors import FvtreeError
from perception.state import FINGERS

MCAP_FILE = "recording.mcap"
PROFILE = "fvtree"  # the MCAP header's profile: JSON messages, no ROS message definitions
LEVELS = {"TRACE": 1, "DEBUG": 1, "INFO": 2, "WARN": 3, "ERROR": 4, "CRITICAL": 5}  # Rerun -> foxglove.LogLevel
LOGS = {"tree/transitions": "tree", "tree/feedback": "feedback", "events": "events", "task/element": "task",
        "commands/arm": "arm", "commands/gripper": "gripper"}  # recorded text logs -> their foxglove.Log name
BEST_LABEL = re.compile(r"load (-?[0-9.]+)$")
FRAME = "base"  # the robot's base frame: poses and the 3-D scene
SCENE_ARRAYS = ("arrows", "spheres", "cylinders", "lines", "triangles", "models")  # primitives not used

Message = tuple[int, str, str, dict]  # log time (ns), topic, schema name, message
Timed = Callable[[list[dict]], Iterator[tuple[int, dict, dict]]]  # rows -> (log time, timestamp field, row)


def export_mcap(run_dir: Path, out: Path | None = None) -> tuple[Path, dict[str, int]]:
    """Write the MCAP file of `run_dir` (default `RUN_DIR/recording.mcap`) atomically; returns its path
    and the number of messages per topic."""
    files = run_recordings(Path(run_dir))
    out = Path(out) if out is not None else Path(run_dir) / MCAP_FILE
    summary = _summary(Path(run_dir))
    messages: list[tuple[int, str, str, bytes]] = []
    offset = 0  # ns: where this session's cell time 0 falls on the log-time axis
    try:
        for session in files:
            found = sorted(((t, topic, schema, json.dumps(message).encode())  # kept as JSON bytes, not dicts
                            for t, topic, schema, message in _messages(read_recording(session), summary, offset)),
                           key=lambda m: m[0])
            if found:
                offset = found[-1][0] + 1
            messages += found
    finally:
        if files[0].parent.name.startswith("fvtree-view-"):  # built from an old run's logs
            shutil.rmtree(files[0].parent, ignore_errors=True)
    counts = _write(out, messages, {"run_dir": str(run_dir), "recordings": ", ".join(f.name for f in files),
                                    "summary": json.dumps(summary)})
    return out, counts


def _summary(run_dir: Path) -> dict:
    try:
        summary = json.loads((run_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return {}
    return summary if isinstance(summary, dict) else {}


def _write(out: Path, messages: list[tuple[int, str, str, bytes]], metadata: dict[str, str]) -> dict[str, int]:
    """Write `messages` (log time, topic, schema, JSON; in log-time order) to a temporary file beside
    `out`, then rename it."""
    if not out.parent.is_dir():
        raise FvtreeError("no such directory for the MCAP file", str(out.parent), field="--out",
                          hint="give a file in an existing directory")
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    schemas: dict[str, int] = {}
    channels: dict[str, int] = {}
    counts: dict[str, int] = {}
    try:
        with open(tmp, "wb") as stream:
            writer = Writer(stream)
            writer.start(profile=PROFILE, library="fvtree")
            writer.add_metadata("fvtree", metadata)
            for log_time, topic, schema, message in messages:
                if schema not in schemas:
                    schemas[schema] = writer.register_schema(schema, "jsonschema", json.dumps(SCHEMAS[schema]).encode())
                if topic not in channels:
                    channels[topic] = writer.register_channel(topic, "json", schemas[schema])
                counts[topic] = counts.get(topic, 0) + 1
                writer.add_message(channels[topic], log_time, message, log_time, sequence=counts[topic])
            writer.finish()
        os.replace(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return counts


def _messages(rec: dict[str, list[dict]], summary: dict, offset: int) -> Iterator[Message]:
    """Every message of one recording (read back), with log times `offset` ns after its cell time 0."""
    def timed(rows: list[dict]) -> Iterator[tuple[int, dict, dict]]:
        for row in rows:
            if row["tick"] is not None:
                t = offset + round(row["cell_time"] * 1e9)
                yield t, {"timestamp": {"sec": t // 1_000_000_000, "nsec": t % 1_000_000_000}}, row

    tree: dict[str, str] = {}
    for t, stamp, row in timed(rec.get("tree/status", [])):
        node, status, feedback = row["node"][0], row["status"][0], (row.get("feedback") or [""])[0]
        tree[node] = status
        yield t, "/tree/status", "fvtree.NodeStatus", {**stamp, "tick": row["tick"], "node": node, "status": status,
                                                        "feedback": feedback, "tree": dict(tree)}
    for entity, name in LOGS.items():
        for t, stamp, row in timed(rec.get(entity, [])):
            for text, level in zip(row["TextLog:text"], row.get("TextLog:level") or ["INFO"] * len(row["TextLog:text"])):
                yield t, f"/{entity}", "foxglove.Log", {**stamp, "level": LEVELS.get(level, LEVELS["INFO"]),
                                                        "message": text, "name": name, "file": "", "line": 0}
    for t, stamp, row in timed(rec.get("cell/tool", [])):
        (x, y, z), (qx, qy, qz, qw) = row["Transform3D:translation"][0], row["Transform3D:quaternion"][0]
        yield t, "/robot/pose", "foxglove.PoseInFrame", {**stamp, "frame_id": FRAME, "pose": {
            "position": {"x": x, "y": y, "z": z}, "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}}
    yield from _scene(rec, timed, offset)
    for t, stamp, row in timed(rec.get("robot/wrench", [])):
        yield t, "/robot/wrench", "fvtree.Wrench", {**stamp, "tick": row["tick"], **_wrench(row["Scalars:scalars"])}
    objects = _by_tick(rec.get("gripper/object", []))
    for t, stamp, row in timed(rec.get("gripper/width", [])):
        yield t, "/gripper", "fvtree.Gripper", {**stamp, "tick": row["tick"], "width": row["Scalars:scalars"][0],
                                                "object": bool(objects.get(row["tick"], [0.0])[0])}
    for finger in FINGERS:
        yield from _finger(finger, rec, timed)
    for entity in sorted(e for e in rec if e.startswith("task/load_profile/") and e.endswith("/best")):
        element = entity.split("/")[2]
        yield from _profiles(element, rec, summary, timed)


def _scene(rec: dict[str, list[dict]], timed: Timed, offset: int) -> Iterator[Message]:
    """The 3-D cell for Foxglove's 3-D panel: the plates (static: at the session's start) and each
    element's box whenever the recording redraws it (its status colour, its as-built pose once placed)."""
    start = {"timestamp": {"sec": offset // 1_000_000_000, "nsec": offset % 1_000_000_000}}
    for row in rec.get("cell/plates", [])[:1]:
        yield offset, "/cell/scene", "foxglove.SceneUpdate", _scene_update(start, "plates", row)
    for entity in sorted(e for e in rec if e.startswith("cell/elements/")):
        for t, stamp, row in timed(rec[entity]):
            if row.get("Boxes3D:centers"):
                yield t, "/cell/scene", "foxglove.SceneUpdate", _scene_update(stamp, entity[len("cell/"):], row)


def _scene_update(stamp: dict, entity: str, row: dict) -> dict:
    """A SceneUpdate replacing the entity `entity` with the recorded Boxes3D `row` (cubes and labels)."""
    centres, halves = row["Boxes3D:centers"], row["Boxes3D:half_sizes"]
    rotations = row.get("Boxes3D:quaternions") or [[0.0, 0.0, 0.0, 1.0]] * len(centres)
    colours = [_rgba(c) for c in row.get("Boxes3D:colors") or [0xC8C8C8FF]]
    colours = colours if len(colours) == len(centres) else colours[:1] * len(centres)  # one for all
    labels = row.get("Boxes3D:labels") or [""] * len(centres)
    poses = [{"position": _vector(c), "orientation": dict(zip("xyzw", q))} for c, q in zip(centres, rotations)]
    cubes = [{"pose": pose, "size": _vector([2 * h for h in half]), "color": colour}
             for pose, half, colour in zip(poses, halves, colours)]
    texts = [{"pose": pose, "billboard": True, "font_size": 14.0, "scale_invariant": True,
              "color": {"r": 1.0, "g": 1.0, "b": 1.0, "a": 1.0}, "text": label} for pose, label in zip(poses, labels)]
    return {"deletions": [], "entities": [{
        **stamp, "frame_id": FRAME, "id": entity, "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False,
        "metadata": [], "cubes": cubes, "texts": texts, **{kind: [] for kind in SCENE_ARRAYS}}]}


def _rgba(packed: int) -> dict[str, float]:
    """A Rerun colour (0xRRGGBBAA) as a foxglove.Color (0..1 each)."""
    return {c: ((packed >> shift) & 0xFF) / 255.0 for c, shift in zip("rgba", (24, 16, 8, 0))}


def _by_tick(rows: list[dict], column: str = "Scalars:scalars") -> dict[int, Any]:
    return {row["tick"]: row[column] for row in rows if row["tick"] is not None and row.get(column) is not None}


def _vector(values: list[float]) -> dict[str, float]:
    return dict(zip("xyz", values))


def _wrench(values: list[float]) -> dict[str, dict]:
    return {"force": _vector(values[0:3]), "torque": _vector(values[3:6])}


def _finger(finger: str, rec: dict[str, list[dict]], timed: Timed) -> Iterator[Message]:
    """One finger's tactile state a tick (its force rows give the ticks) and its camera frames."""
    base = f"fv/{finger}"
    torque, slip, obj, health = (_by_tick(rec.get(f"{base}/{what}", [])) for what in ("torque", "slip", "object",
                                                                                         "health"))
    for t, stamp, row in timed(rec.get(f"{base}/force", [])):
        tick = row["tick"]
        if tick not in health:
            continue
        area, cx, cy, orientation = obj[tick]
        healthy, valid, present = health[tick]
        yield t, f"/{base}/state", "fvtree.FingerState", {
            **stamp, "tick": tick, "force": _vector(row["Scalars:scalars"]), "torque": _vector(torque[tick]),
            "slip": slip[tick][0], "object": {"area": area, "centroid": {"x": cx, "y": cy}, "orientation": orientation,
                                              "present": bool(present)},
            "healthy": bool(healthy), "valid_markers": valid}
    for t, stamp, row in timed(rec.get(f"{base}/markers/image", [])):
        media = (row.get("EncodedImage:media_type") or ["image/jpeg"])[0]
        yield t, f"/{base}/image", "foxglove.CompressedImage", {
            **stamp, "frame_id": f"fv_{finger}", "format": media.split("/")[-1],
            "data": base64.b64encode(bytes(row["EncodedImage:blob"][0])).decode("ascii")}


def _profiles(element: str, rec: dict[str, list[dict]], summary: dict, timed: Timed) -> Iterator[Message]:
    """Each load profile of `element` as recorded: the recording draws it scaled (the largest load
    `PROFILE_HEIGHT` high, y down), so loads are put back from the chosen point's load (its label, to
    two decimals, or the summary's measured load of the element when that rounds to it)."""
    base = f"task/load_profile/{element}"
    loads, smoothed = (_by_tick(rec.get(f"{base}/{what}", []), "LineStrips2D:strips") for what in ("load", "smoothed"))
    measured = summary.get("elements", {}).get(element, {}).get("measured_load_px")
    for t, stamp, row in timed(rec.get(f"{base}/best", [])):
        tick = row["tick"]
        (best_position, best_y), label = row["Points2D:positions"][0], row["Points2D:labels"][0]
        found = BEST_LABEL.search(label)
        assert found is not None  # the recorder labels every best point so (RunRecorder._log_profile)
        best_load = float(found.group(1))
        if isinstance(measured, (int, float)) and round(measured, 2) == best_load:
            best_load = measured
        scale = best_y / best_load if best_load and best_y else -PROFILE_HEIGHT
        strip, smooth = loads[tick][0], smoothed[tick][0]
        yield t, "/task/load_profile", "fvtree.LoadProfile", {
            **stamp, "tick": tick, "element": element, "position": [p[0] for p in strip],
            "load": [p[1] / scale for p in strip], "smoothed": [p[1] / scale for p in smooth],
            "best_position": best_position, "best_load": best_load}
