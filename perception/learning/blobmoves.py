"""Marker logs from other FingerVision software (`BlobMoves`) into the recording format, so
`fvtree train` learns from real sensor data as ForceLearn did in the paper.

One log file holds one trial (JSON or YAML). Per frame, per marker, the original software's six
numbers in pixels: `[Pox, Poy, So, DPx, DPy, DS]` = origin x, origin y, origin size, displacement
x, displacement y, size change. Accepted layouts of a trial:

    {"frames": [[[Pox, Poy, So, DPx, DPy, DS], ...], ...],          # or frames of {"BlobMoves": [...]}
     "load": 2.5,                  # N applied in this trial (ForceLearn), or
     "mass": 584.2,                # g hung on the sensor (public calibration logs): weight in N
     "label": "flour",             # a class (StirLearn), instead of or beside the load
     "finger": "left", "width": 320, "height": 240, "fps": 30}   # optional, these defaults

and `MoveData[].BlobMoves` for the frames, with `frame_width` / `frame_height`, as the public
FingerVision calibration logs store them. Each frame becomes one row: the markers as a
MarkerField on the log's finger (the other finger empty), the wrench the pipeline computes from
them, and the labels `scale_force` (the load, what ForceLearn learns) and `substance` (the
label, what StirLearn learns); each trial is one segment, so whole trials are held out together.
Every frame lists the markers of the frame before, in the same order; markers found after
calibration (as `fvtree`'s pipeline adds them) are appended and count from the frame they appear in.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from fvfiles.errors import FvtreeError
from fvfiles.yaml_source import load_file
from perception.learning.dataset import Dataset
from perception.learning.features import columns, feature_spec, tick_features
from perception.state import FINGERS, MarkerField, TactileState
from perception.wrench import wrench

FIELDS = ("Pox", "Poy", "So", "DPx", "DPy", "DS")
MAX_BYTES = 64 * 2**20  # a log larger than this is not a trial
GRAVITY = 9.81


class LogError(FvtreeError, ValueError):
    """A marker log that cannot be imported; names the file and the frame or field."""


def _read(path: Path) -> dict:
    """The log's top-level mapping, from JSON or (hardened) YAML."""
    if path.stat().st_size > MAX_BYTES:
        raise LogError(f"larger than {MAX_BYTES // 2**20} MiB", str(path))
    if path.suffix.lower() in (".yaml", ".yml"):
        data = load_file(path)
    else:
        try:
            data = json.loads(path.read_text(encoding="utf-8"), parse_constant=_no_constant)
        except ValueError as exc:  # undecodable text, bad JSON, NaN or Infinity
            raise LogError(f"not a JSON marker log ({exc})", str(path)) from None
    if not isinstance(data, dict):
        raise LogError("a marker log is a mapping with 'frames' (or 'MoveData') and 'load', 'mass' or 'label'",
                       str(path))
    return data


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number a marker log may hold")


def _frames(data: dict, file: str) -> tuple[list, str]:
    """The frames' BlobMoves lists and the field they came from."""
    if "frames" in data:
        frames, where = data["frames"], "frames"
    elif "MoveData" in data:
        frames, where = data["MoveData"], "MoveData"
    else:
        raise LogError("no frames: expected 'frames' or 'MoveData'", file)
    if not isinstance(frames, list) or not frames:
        raise LogError(f"'{where}' must be a non-empty list of frames", file, field=where)
    out = []
    for i, frame in enumerate(frames):
        moves = frame.get("BlobMoves") if isinstance(frame, dict) else frame
        if not isinstance(moves, list):
            raise LogError("a frame is a list of markers (or a mapping with 'BlobMoves')", file,
                           field=f"{where}[{i}]")
        out.append(moves)
    return out, where


def _markers(moves: list, n: int, before: str, file: str, field: str) -> np.ndarray:
    """(M, 6) array of one frame's markers, checked: M = n, the count of the frame `before`, or more
    (markers found after calibration are appended, as `fvtree`'s pipeline does)."""
    if len(moves) < n:
        raise LogError(f"{len(moves)} markers where {before} has {n}: every frame lists every marker in the same "
                       "order (markers found later are appended)", file, field=field)
    rows = []
    for j, marker in enumerate(moves):
        if isinstance(marker, dict):
            missing = [k for k in FIELDS if k not in marker]
            if missing:
                raise LogError(f"marker {j} lacks {', '.join(missing)}", file, field=field)
            marker = [marker[k] for k in FIELDS]
        if not isinstance(marker, list) or len(marker) != len(FIELDS):
            raise LogError(f"marker {j} must be [{', '.join(FIELDS)}], got {marker!r:.60}", file, field=field)
        for k, value in zip(FIELDS, marker):
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                raise LogError(f"marker {j}: {k} must be a finite number, got {value!r:.30}", file, field=field)
        rows.append(marker)
    return np.array(rows, float)


def _number(data: dict, key: str, file: str, minimum: float = -math.inf) -> float | None:
    value = data.get(key)
    if value is None:
        return None
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value) or value < minimum:
        raise LogError(f"{key} must be a finite number >= {minimum:g}, got {value!r:.30}", file, field=key)
    return float(value)


def _load(data: dict, file: str) -> float | None:
    """The trial's applied load in N: `load`, or the weight of `mass` grams."""
    load = _number(data, "load", file)
    mass = _number(data, "mass", file, minimum=0.0)
    return load if load is not None else (mass * GRAVITY / 1000.0 if mass is not None else None)


def read_trial(path: str | Path) -> dict:
    """One trial of a log: markers (F, N, 6) (NaN where a marker appended later is not yet listed), load (N) or None, label or None, finger, image size, fps."""
    path = Path(path)
    file = str(path)
    data = _read(path)
    frames, where = _frames(data, file)
    n = len(frames[0])
    if n == 0:
        raise LogError("the first frame lists no markers", file, field=f"{where}[0]")
    rows = [_markers(frames[0], n, "the first frame", file, f"{where}[0]")]
    for i, moves in enumerate(frames[1:], 1):
        before = "the first frame" if len(rows[-1]) == n else f"{where}[{i - 1}]"
        rows.append(_markers(moves, len(rows[-1]), before, file, f"{where}[{i}]"))
    markers = np.full((len(rows), len(rows[-1]), len(FIELDS)), np.nan)  # NaN: a marker not yet found
    for i, m in enumerate(rows):
        markers[i, :len(m)] = m
    load, label = _load(data, file), data.get("label")
    if load is None and label is None:
        raise LogError("no load and no label: give 'load' (N) or 'mass' (g) for ForceLearn, 'label' for StirLearn",
                       file)
    if label is not None and not isinstance(label, str):
        raise LogError(f"label must be a text, got {label!r:.30}", file, field="label")
    finger = data.get("finger", FINGERS[0])
    if finger not in FINGERS:
        raise LogError(f"finger must be one of {', '.join(FINGERS)}, got {finger!r:.30}", file, field="finger")
    width = _number(data, "width", file, 1) or _number(data, "frame_width", file, 1) or 320
    height = _number(data, "height", file, 1) or _number(data, "frame_height", file, 1) or 240
    fps = _number(data, "fps", file, 1e-3) or 30.0
    return {"markers": markers, "load": load, "label": label, "finger": finger,
            "image_size": (int(width), int(height)), "fps": fps}


def _state(finger: str, stamp: float, m: np.ndarray, image_size: tuple[int, int]) -> TactileState:
    """The TactileState of one frame's (N, 6) markers (NaN rows: not yet found), with the pipeline's wrench."""
    m = m[~np.isnan(m[:, 0])]
    markers = MarkerField(origin=m[:, 0:2], position=m[:, 0:2] + m[:, 3:5], origin_size=m[:, 2],
                          size=m[:, 2] + m[:, 5], valid=np.ones(len(m), bool), image_size=image_size)
    force, torque = wrench(markers, finger)
    return TactileState(finger, stamp, markers, force, torque)


def import_logs(paths: list[str | Path]) -> Dataset:
    """A recording of the trials in `paths` (one segment and one run per file)."""
    if not paths:
        raise LogError("no marker logs given")
    rows, stamps, runs, loads, labels = [], [], [], [], []
    for index, path in enumerate(paths):
        trial = read_trial(path)
        for k, frame in enumerate(trial["markers"]):
            stamp = k / trial["fps"]
            state = _state(trial["finger"], stamp, frame, trial["image_size"])
            empty = TactileState(FINGERS[1] if trial["finger"] == FINGERS[0] else FINGERS[0], stamp)
            pair = (state, empty) if trial["finger"] == FINGERS[0] else (empty, state)
            rows.append(tick_features(*pair))
            stamps.append(stamp)
            runs.append(index)
            loads.append(np.nan if trial["load"] is None else trial["load"])
            labels.append(trial["label"] or "none")
    runs_array = np.array(runs, np.int32)
    header = {"source": {"logs": [str(p) for p in paths], "format": "BlobMoves [Pox, Poy, So, DPx, DPy, DS] px"},
              "feature_spec": feature_spec(), "columns": columns(), "groups": "segment",
              "label_info": {"scale_force": {"unit": "N", "what": "the trial's applied load"}}}
    out_labels = {}
    if not np.isnan(loads).all():
        out_labels["scale_force"] = np.array(loads)
    if any(label != "none" for label in labels):
        out_labels["substance"] = np.array(labels)
    return Dataset(header, np.array(stamps), runs_array, runs_array.copy(), np.array(rows, np.float32), out_labels)
