"""The rows of a read-back recording (`assembly.observe.readback`) as the MCAP exports use them:
stamped on the wall clock (the session's start plus the row's cell time), and looked up by tick."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

NS = 1_000_000_000
FRAME = "base"  # the robot's base frame: poses and the 3-D scene
TOOL_FRAME = "tool"  # the robot's tool (TCP): its wrench
LOGS = {"tree/transitions": "tree", "tree/feedback": "feedback", "events": "events", "task/element": "task",
        "commands/arm": "arm", "commands/gripper": "gripper"}  # recorded text logs -> the name they log under

Recording = dict[str, list[dict]]


def finger_frame(finger: str) -> str:
    """The frame of a FingerVision fingertip (its camera and its force/torque)."""
    return f"fv_{finger}"


def timed(rows: list[dict], start: int) -> Iterator[tuple[int, dict]]:
    """(wall-clock ns, row) of each row on the timelines (static rows have no tick): `start` is
    the wall-clock ns of the session's cell time 0."""
    for row in rows:
        if row["tick"] is not None:
            yield start + round(row["cell_time"] * 1e9), row


def by_tick(rows: list[dict], column: str = "Scalars:scalars") -> dict[int, Any]:
    """Tick -> the value of `column` in that tick's row."""
    return {row["tick"]: row[column] for row in rows if row["tick"] is not None and row.get(column) is not None}


def text_logs(rec: Recording, start: int) -> Iterator[tuple[int, str, str, str, dict]]:
    """Every recorded text (events, transitions, feedback, element, commands): (wall-clock ns,
    entity, logger name, Rerun level, row)."""
    for entity, name in LOGS.items():
        for t, row in timed(rec.get(entity, []), start):
            texts = row["TextLog:text"]
            for text, level in zip(texts, row.get("TextLog:level") or ["INFO"] * len(texts)):
                yield t, entity, name, text, {**row, "level": level}


def finger_states(finger: str, rec: Recording, start: int) -> Iterator[tuple[int, dict]]:
    """(wall-clock ns, state) of one finger a tick: `tick`, `cell_time`, `force`, `torque` (xyz lists),
    `slip`, `area`, `centroid` (xy), `orientation`, `healthy`, `valid_markers` and `present`."""
    base = f"fv/{finger}"
    torque, slip, obj, health = (by_tick(rec.get(f"{base}/{what}", [])) for what in ("torque", "slip", "object",
                                                                                       "health"))
    for t, row in timed(rec.get(f"{base}/force", []), start):
        tick = row["tick"]
        if tick not in health:
            continue
        area, cx, cy, orientation = obj[tick]
        healthy, valid, present = health[tick]
        yield t, {"tick": tick, "cell_time": row["cell_time"], "force": row["Scalars:scalars"],
                  "torque": torque[tick], "slip": slip[tick][0], "area": area, "centroid": [cx, cy],
                  "orientation": orientation, "healthy": bool(healthy), "valid_markers": valid,
                  "present": bool(present)}


def camera_frames(finger: str, rec: Recording, start: int) -> Iterator[tuple[int, dict, str, bytes]]:
    """(wall-clock ns, row, format such as `jpeg`, encoded bytes) of each recorded camera frame."""
    for t, row in timed(rec.get(f"fv/{finger}/markers/image", []), start):
        media = (row.get("EncodedImage:media_type") or ["image/jpeg"])[0]
        yield t, row, media.split("/")[-1], bytes(row["EncodedImage:blob"][0])

