"""A recording's messages for Foxglove: JSON messages of Foxglove's well-known schemas (Log,
PoseInFrame, SceneUpdate, CompressedImage) and of fvtree's own (`schemas`).

Topics: `/tree/status` (on change), `/tree/transitions`, `/tree/feedback`, `/events`, `/task/element`,
`/commands/arm`, `/commands/gripper` (Log panel), `/task/load_profile`, `/robot/pose` (the tool),
`/robot/wrench`, `/gripper`, `/cell/scene` (plates and elements as 3-D boxes coloured by status),
and per finger `/fv/<finger>/state` and `/fv/<finger>/image` (the JPEG camera frames, when the run
recorded them)."""

from __future__ import annotations

import base64
import re
from collections.abc import Iterator

from assembly.interop.mcap.rows import (
    FRAME,
    NS,
    Recording,
    by_tick,
    camera_frames,
    finger_frame,
    finger_states,
    text_logs,
    timed,
)
from assembly.observe.recorder import PROFILE_HEIGHT
from perception.state import FINGERS

LEVELS = {"TRACE": 1, "DEBUG": 1, "INFO": 2, "WARN": 3, "ERROR": 4, "CRITICAL": 5}  # Rerun -> foxglove.LogLevel
BEST_LABEL = re.compile(r"load (-?[0-9.]+)$")
SCENE_ARRAYS = ("arrows", "spheres", "cylinders", "lines", "triangles", "models")  # primitives not used

Message = tuple[int, str, str, dict]  # log time (wall-clock ns), topic, schema name, message


def stamp(t: int) -> dict:
    """A Foxglove `timestamp` field of wall-clock ns `t`."""
    return {"timestamp": {"sec": t // NS, "nsec": t % NS}}


def messages(rec: Recording, summary: dict, start: int) -> Iterator[Message]:
    """Every message of one recording (read back); `start`: the wall-clock ns of its cell time 0."""
    tree: dict[str, str] = {}
    for t, row in timed(rec.get("tree/status", []), start):
        node, status, feedback = row["node"][0], row["status"][0], (row.get("feedback") or [""])[0]
        tree[node] = status
        yield t, "/tree/status", "fvtree.NodeStatus", {**stamp(t), "tick": row["tick"], "node": node,
                                                        "status": status, "feedback": feedback, "tree": dict(tree)}
    for t, entity, name, text, row in text_logs(rec, start):
        yield t, f"/{entity}", "foxglove.Log", {**stamp(t), "level": LEVELS.get(row["level"], LEVELS["INFO"]),
                                                "message": text, "name": name, "file": "", "line": 0}
    for t, row in timed(rec.get("cell/tool", []), start):
        (x, y, z), (qx, qy, qz, qw) = row["Transform3D:translation"][0], row["Transform3D:quaternion"][0]
        yield t, "/robot/pose", "foxglove.PoseInFrame", {**stamp(t), "frame_id": FRAME, "pose": {
            "position": {"x": x, "y": y, "z": z}, "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}}
    yield from _scene(rec, start)
    for t, row in timed(rec.get("robot/wrench", []), start):
        yield t, "/robot/wrench", "fvtree.Wrench", {**stamp(t), "tick": row["tick"], **_wrench(row["Scalars:scalars"])}
    objects = by_tick(rec.get("gripper/object", []))
    for t, row in timed(rec.get("gripper/width", []), start):
        yield t, "/gripper", "fvtree.Gripper", {**stamp(t), "tick": row["tick"], "width": row["Scalars:scalars"][0],
                                                "object": bool(objects.get(row["tick"], [0.0])[0])}
    for finger in FINGERS:
        for t, s in finger_states(finger, rec, start):
            yield t, f"/fv/{finger}/state", "fvtree.FingerState", {
                **stamp(t), "tick": s["tick"], "force": _vector(s["force"]), "torque": _vector(s["torque"]),
                "slip": s["slip"], "object": {"area": s["area"], "centroid": _vector(s["centroid"]),
                                              "orientation": s["orientation"], "present": s["present"]},
                "healthy": s["healthy"], "valid_markers": s["valid_markers"]}
        for t, _, image_format, data in camera_frames(finger, rec, start):
            yield t, f"/fv/{finger}/image", "foxglove.CompressedImage", {
                **stamp(t), "frame_id": finger_frame(finger), "format": image_format,
                "data": base64.b64encode(data).decode("ascii")}
    for entity in sorted(e for e in rec if e.startswith("task/load_profile/") and e.endswith("/best")):
        yield from _profiles(entity.split("/")[2], rec, summary, start)


def _scene(rec: Recording, start: int) -> Iterator[Message]:
    """The 3-D cell for Foxglove's 3-D panel: the plates (static: at the session's start) and each
    element's box whenever the recording redraws it (its status colour, its as-built pose once placed)."""
    for row in rec.get("cell/plates", [])[:1]:
        yield start, "/cell/scene", "foxglove.SceneUpdate", _scene_update(stamp(start), "plates", row)
    for entity in sorted(e for e in rec if e.startswith("cell/elements/")):
        for t, row in timed(rec[entity], start):
            if row.get("Boxes3D:centers"):
                yield t, "/cell/scene", "foxglove.SceneUpdate", _scene_update(stamp(t), entity[len("cell/"):], row)


def _scene_update(when: dict, entity: str, row: dict) -> dict:
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
        **when, "frame_id": FRAME, "id": entity, "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False,
        "metadata": [], "cubes": cubes, "texts": texts, **{kind: [] for kind in SCENE_ARRAYS}}]}


def _rgba(packed: int) -> dict[str, float]:
    """A Rerun colour (0xRRGGBBAA) as a foxglove.Color (0..1 each)."""
    return {c: ((packed >> shift) & 0xFF) / 255.0 for c, shift in zip("rgba", (24, 16, 8, 0))}


def _vector(values: list[float]) -> dict[str, float]:
    return dict(zip("xyz", values))


def _wrench(values: list[float]) -> dict[str, dict]:
    return {"force": _vector(values[0:3]), "torque": _vector(values[3:6])}


def _profiles(element: str, rec: Recording, summary: dict, start: int) -> Iterator[Message]:
    """Each load profile of `element` as recorded: the recording draws it scaled (the largest load
    `PROFILE_HEIGHT` high, y down), so loads are put back from the chosen point's load (its label, to
    two decimals, or the summary's measured load of the element when that rounds to it)."""
    base = f"task/load_profile/{element}"
    loads, smoothed = (by_tick(rec.get(f"{base}/{what}", []), "LineStrips2D:strips") for what in ("load", "smoothed"))
    measured = summary.get("elements", {}).get(element, {}).get("measured_load_px")
    for t, row in timed(rec.get(f"{base}/best", []), start):
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
            **stamp(t), "tick": tick, "element": element, "position": [p[0] for p in strip],
            "load": [p[1] / scale for p in strip], "smoothed": [p[1] / scale for p in smooth],
            "best_position": best_position, "best_load": best_load}
