"""`fvtree export RUN_DIR`: a run as an MCAP file, read from the run's Rerun recordings through
`readback` (an old run directory without one: the recording `replay` builds from its logs).

Two kinds (`foxglove`, `ros2`): JSON messages with Foxglove's JSON schemas (`RUN_DIR/recording.mcap`),
or, with `--ros2`, a ROS 2 bag of standard message types in CDR with `ros2msg` schemas
(`RUN_DIR/recording.ros2.mcap`, profile `ros2`), which `ros2 bag play` plays. Log, publish and header
times are on the wall clock: a session's cell time 0 is the time of its `start` event in the event
log (else the recording's own start time), so a run lines up with other recordings of the same day;
a resumed run's sessions follow one another (each session's cell clock starts again at 0; a session
never starts before the one before it ended)."""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.writer import Writer

from assembly.interop.mcap import foxglove, ros2
from assembly.interop.mcap.rows import Recording
from assembly.interop.mcap.schemas import SCHEMAS
from assembly.observe.readback import read_recording
from assembly.observe.replay import run_recordings
from fvfiles.errors import FvtreeError
from fvfiles.json_files import read_json_lines

MCAP_FILE, ROS2_FILE = "recording.mcap", "recording.ros2.mcap"
START_INFO = "RecordingInfo:start_time"  # a Rerun recording's wall-clock start (ns), on its `__properties`


@dataclass(frozen=True)
class Kind:
    """One kind of export: its default file, MCAP profile, encodings and messages."""

    file: str
    profile: str
    schema_encoding: str
    message_encoding: str
    schema: Callable[[str], bytes]  # a schema's name -> its data
    messages: Callable[[Recording, dict, int], Iterator[tuple[int, str, str, Any]]]
    encode: Callable[[Any], bytes]  # a message -> its bytes


FOXGLOVE = Kind(MCAP_FILE, "", "jsonschema", "json", lambda name: json.dumps(SCHEMAS[name]).encode(),
                foxglove.messages, lambda message: json.dumps(message).encode())
ROS2 = Kind(ROS2_FILE, "ros2", "ros2msg", "cdr", ros2.definition, ros2.messages, bytes)  # CDR already


def export_mcap(run_dir: Path, out: Path | None = None, ros: bool = False) -> tuple[Path, dict[str, int]]:
    """Write the MCAP file of `run_dir` (Foxglove JSON, or ROS 2 CDR when `ros`) atomically; returns
    its path and the number of messages per topic."""
    run_dir = Path(run_dir)
    kind = ROS2 if ros else FOXGLOVE
    files = run_recordings(run_dir)
    out = Path(out) if out is not None else run_dir / kind.file
    summary = _json(run_dir / "summary.json")
    starts = [e["time"] for e in read_json_lines(run_dir / "events.jsonl")
              if e.get("event") == "start" and isinstance(e.get("time"), (int, float))]
    messages: list[tuple[int, str, str, bytes]] = []
    sessions: list[dict] = []
    floor = 0  # ns: no session starts before the one before it ended
    try:
        for n, session in enumerate(files):
            rec = read_recording(session)
            start = max(_start(rec, starts, n, session), floor)
            found = sorted(((t, topic, schema, kind.encode(message))  # kept as bytes, not objects
                            for t, topic, schema, message in kind.messages(rec, summary, start)),
                           key=lambda m: m[0])
            if found:
                floor = found[-1][0] + 1
            sessions.append({"recording": session.name, "start_ns": start})
            messages += found
    finally:
        if files[0].parent.name.startswith("fvtree-view-"):  # built from an old run's logs
            shutil.rmtree(files[0].parent, ignore_errors=True)
    counts = _write(out, kind, messages, {"run_dir": str(run_dir), "recordings": ", ".join(f.name for f in files),
                                          "sessions": json.dumps(sessions), "summary": json.dumps(summary)})
    return out, counts


def _start(rec: Recording, starts: list[float], n: int, session: Path) -> int:
    """The wall-clock ns of session `n`'s cell time 0: its `start` event, else its recording's start."""
    if n < len(starts):
        return round(starts[n] * 1e9)
    for row in rec.get("__properties", []):
        if row.get(START_INFO):
            return int(row[START_INFO][0])
    raise FvtreeError("no start time: the run has no `start` event and the recording none of its own",
                      str(session), hint="export a run directory that `fvtree run` made")


def _json(path: Path) -> dict:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _write(out: Path, kind: Kind, messages: list[tuple[int, str, str, bytes]],
           metadata: dict[str, str]) -> dict[str, int]:
    """Write `messages` (log time, topic, schema, encoded message; in log-time order) to a temporary
    file beside `out`, then rename it."""
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
            writer.start(profile=kind.profile, library="fvtree")
            writer.add_metadata("fvtree", metadata)
            for log_time, topic, schema, message in messages:
                if schema not in schemas:
                    schemas[schema] = writer.register_schema(schema, kind.schema_encoding, kind.schema(schema))
                if topic not in channels:
                    channels[topic] = writer.register_channel(topic, kind.message_encoding, schemas[schema])
                counts[topic] = counts.get(topic, 0) + 1
                writer.add_message(channels[topic], log_time, message, log_time, sequence=counts[topic])
            writer.finish()
        os.replace(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return counts
