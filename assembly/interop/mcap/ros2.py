"""A recording's messages for ROS 2 tools (`ros2 bag play`, rqt, Foxglove, PlotJuggler): standard
message types, CDR-serialised by the `rosbags` type store of ROS 2 Humble (whose definitions go
into the MCAP schemas, `ros2msg` encoded), every header stamped on the wall clock.

Topics: `/robot/pose` (geometry_msgs/msg/PoseStamped, the TCP in `base`), `/robot/wrench`
(geometry_msgs/msg/WrenchStamped, the TCP's, in `tool`), `/gripper/joint_states`
(sensor_msgs/msg/JointState: `gripper_width`, m), per finger `/fv/<finger>/wrench` (WrenchStamped,
the fingertip's force and torque, in `fv_<finger>`) and `/fv/<finger>/image/compressed`
(sensor_msgs/msg/CompressedImage, when the run recorded camera frames), `/tree/status`
(diagnostic_msgs/msg/DiagnosticArray: each tick with status changes, one DiagnosticStatus per
change, in order, named by the node's path, its status as the message, `tick`, `cell_time`,
`feedback` as values), `/rosout` (rcl_interfaces/msg/Log: events, transitions, feedback, element,
arm and gripper commands, named `fvtree.<log>`) and `/cell/time` (sensor_msgs/msg/TimeReference,
a tick: the cell clock's time as `time_ref`, so that cell time stays readable beside the wall-clock
stamps; `source` is `cell tick N`)."""

from __future__ import annotations

from collections.abc import Iterator
from functools import lru_cache
from itertools import groupby
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore

from assembly.interop.mcap.rows import (
    FRAME,
    NS,
    TOOL_FRAME,
    Recording,
    camera_frames,
    finger_frame,
    finger_states,
    text_logs,
    timed,
)
from perception.state import FINGERS

STORE = Stores.ROS2_HUMBLE
POSE, WRENCH, JOINTS = "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/WrenchStamped", "sensor_msgs/msg/JointState"
IMAGE, DIAGNOSTICS, LOG = "sensor_msgs/msg/CompressedImage", "diagnostic_msgs/msg/DiagnosticArray", "rcl_interfaces/msg/Log"
TIME_REFERENCE = "sensor_msgs/msg/TimeReference"
LOG_LEVELS = {"TRACE": 10, "DEBUG": 10, "INFO": 20, "WARN": 30, "ERROR": 40, "CRITICAL": 50}  # Rerun -> rcl Log
STATUS_LEVELS = {"FAILURE": 1}  # diagnostic_msgs/DiagnosticStatus level (WARN); every other status is OK (0)
GRIPPER_JOINT = "gripper_width"

Message = tuple[int, str, str, bytes]  # log time (wall-clock ns), topic, message type, CDR bytes


@lru_cache(maxsize=1)
def _store() -> Any:
    return get_typestore(STORE)


def definition(typename: str) -> bytes:
    """The message definition of `typename` as ROS 2 writes it into a bag's `ros2msg` schema (the
    type's fields, then each type it uses after a line of `=`)."""
    text, _ = _store().generate_msgdef(typename, ros_version=2)
    return text.encode()


def messages(rec: Recording, summary: dict, start: int) -> Iterator[Message]:
    """Every ROS 2 message of one recording (read back); `start`: the wall-clock ns of its cell time 0.
    (`summary` is not used: the load profiles have no standard message.)"""
    store = _store()
    types = store.types
    cdr = store.serialize_cdr

    def header(t: int, frame: str) -> Any:
        return types["std_msgs/msg/Header"](stamp=_time(t), frame_id=frame)

    def vector(values: list[float]) -> Any:
        x, y, z = values
        return types["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    def wrench(t: int, frame: str, force: list[float], torque: list[float]) -> bytes:
        return bytes(cdr(types[WRENCH](header=header(t, frame), wrench=types["geometry_msgs/msg/Wrench"](
            force=vector(force), torque=vector(torque))), WRENCH))

    for t, row in timed(rec.get("cell/tool", []), start):
        (x, y, z), (qx, qy, qz, qw) = row["Transform3D:translation"][0], row["Transform3D:quaternion"][0]
        pose = types["geometry_msgs/msg/Pose"](position=types["geometry_msgs/msg/Point"](x=x, y=y, z=z),
                                               orientation=types["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw))
        yield t, "/robot/pose", POSE, bytes(cdr(types[POSE](header=header(t, FRAME), pose=pose), POSE))
        yield t, "/cell/time", TIME_REFERENCE, bytes(cdr(types[TIME_REFERENCE](
            header=header(t, ""), time_ref=_time(round(row["cell_time"] * 1e9)), source=f"cell tick {row['tick']}"),
            TIME_REFERENCE))
    for t, row in timed(rec.get("robot/wrench", []), start):
        values = row["Scalars:scalars"]
        yield t, "/robot/wrench", WRENCH, wrench(t, TOOL_FRAME, values[0:3], values[3:6])
    for t, row in timed(rec.get("gripper/width", []), start):
        yield t, "/gripper/joint_states", JOINTS, bytes(cdr(types[JOINTS](
            header=header(t, ""), name=[GRIPPER_JOINT], position=_floats([row["Scalars:scalars"][0]]),
            velocity=_floats([]), effort=_floats([])), JOINTS))
    for finger in FINGERS:
        frame = finger_frame(finger)
        for t, state in finger_states(finger, rec, start):
            yield t, f"/fv/{finger}/wrench", WRENCH, wrench(t, frame, state["force"], state["torque"])
        for t, _, image_format, data in camera_frames(finger, rec, start):
            yield t, f"/fv/{finger}/image/compressed", IMAGE, bytes(cdr(types[IMAGE](
                header=header(t, frame), format=image_format, data=_bytes(data)), IMAGE))
    yield from _statuses(rec, start)
    for t, entity, name, text, row in text_logs(rec, start):
        yield t, "/rosout", LOG, bytes(cdr(types[LOG](
            stamp=_time(t), level=LOG_LEVELS.get(row["level"], LOG_LEVELS["INFO"]), name=f"fvtree.{name}", msg=text,
            file=entity, function="", line=0), LOG))


def _statuses(rec: Recording, start: int) -> Iterator[Message]:
    """One DiagnosticArray a tick with status changes, holding every change of that tick in order."""
    types = _store().types
    status, value = types["diagnostic_msgs/msg/DiagnosticStatus"], types["diagnostic_msgs/msg/KeyValue"]
    rows = sorted(timed(rec.get("tree/status", []), start), key=lambda r: (r[0], _order(r[1])))
    for t, changes in groupby(rows, key=lambda r: r[0]):
        statuses = []
        for _, row in changes:
            node, to, feedback = row["node"][0], row["status"][0], (row.get("feedback") or [""])[0]
            statuses.append(status(level=STATUS_LEVELS.get(to, 0), name=node, message=to, hardware_id="fvtree",
                                   values=[value(key="tick", value=str(row["tick"])),
                                           value(key="cell_time", value=repr(row["cell_time"])),
                                           value(key="feedback", value=feedback)]))
        yield t, "/tree/status", DIAGNOSTICS, bytes(_store().serialize_cdr(types[DIAGNOSTICS](
            header=types["std_msgs/msg/Header"](stamp=_time(t), frame_id=""), status=statuses), DIAGNOSTICS))


def _order(row: dict) -> int:
    """A status row's place among the changes of its tick (its `change` index where recorded)."""
    return row.get("change") or 0


def _time(t: int) -> Any:
    return _store().types["builtin_interfaces/msg/Time"](sec=t // NS, nanosec=t % NS)


def _floats(values: list[float]) -> np.ndarray:
    return np.array(values, dtype=np.float64)


def _bytes(data: bytes) -> np.ndarray:
    return np.frombuffer(data, dtype=np.uint8)
