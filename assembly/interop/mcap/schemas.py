"""JSON schemas of the MCAP export's messages: Foxglove's well-known ones (`foxglove.Log`,
`foxglove.CompressedImage`, `foxglove.PoseInFrame`, `foxglove.SceneUpdate`: the titles, properties,
types and `required` lists of Foxglove's official JSON schemas, so its Log, Image and 3-D panels show
them; only the field descriptions are left out, and the SceneEntity primitives and deletions the
export leaves empty are plain arrays) and fvtree's own for what has no Foxglove type.
tests/test_export_mcap.py checks them against the official schemas of the `@foxglove/schemas` package."""

from __future__ import annotations

from typing import Any

NUMBER, INTEGER, STRING, BOOLEAN = ({"type": t} for t in ("number", "integer", "string", "boolean"))
NUMBERS = {"type": "array", "items": NUMBER}
TIME = {"type": "object", "title": "time", "properties": {"sec": {"type": "integer", "minimum": 0},
                                                          "nsec": {"type": "integer", "minimum": 0,
                                                                   "maximum": 999999999}}}
LOG_LEVELS = ("UNKNOWN", "DEBUG", "INFO", "WARNING", "ERROR", "FATAL")  # foxglove.LogLevel, by value


def _object(title: str, description: str, **properties: Any) -> dict:
    """An object schema requiring every field (as Foxglove's official schemas do)."""
    return {"title": title, "description": description, "type": "object", "properties": properties,
            "required": list(properties)}


def _xyz(title: str, description: str, names: str = "xyz") -> dict:
    return _object(title, description, **{n: NUMBER for n in names})


ARRAY = {"type": "array"}  # a SceneEntity's primitives the export leaves empty
DURATION = {"type": "object", "title": "duration", "properties": {"sec": INTEGER,
                                                                  "nsec": {"type": "integer", "minimum": 0,
                                                                           "maximum": 999999999}}}
TICK = {"type": "integer", "minimum": 0, "description": "tick of the run (the cell clock's period apart)"}
VECTOR3 = _xyz("foxglove.Vector3", "a vector in 3-D space")
POSE = _object("foxglove.Pose", "A position and orientation for an object or reference frame in 3D space",
               position=VECTOR3, orientation=_xyz("foxglove.Quaternion", "a rotation", "xyzw"))
COLOR = _object("foxglove.Color", "A color in RGBA format", **{c: NUMBER for c in "rgba"})
CUBE = _object("foxglove.CubePrimitive", "A primitive representing a cube or rectangular prism", pose=POSE,
               size=VECTOR3, color=COLOR)
TEXT = _object("foxglove.TextPrimitive", "A primitive representing a text label", pose=POSE, billboard=BOOLEAN,
               font_size=NUMBER, scale_invariant=BOOLEAN, color=COLOR, text=STRING)

SCHEMAS: dict[str, dict] = {
    "foxglove.Log": _object(
        "foxglove.Log", "A log message", timestamp=TIME,
        level={"title": "foxglove.LogLevel", "description": "Log level",
               "oneOf": [{"title": name, "const": value} for value, name in enumerate(LOG_LEVELS)]},
        message=STRING, name=STRING, file=STRING, line={"type": "integer", "minimum": 0}),
    "foxglove.CompressedImage": _object(
        "foxglove.CompressedImage", "A compressed image", timestamp=TIME, frame_id=STRING,
        data={"type": "string", "contentEncoding": "base64"}, format=STRING),
    "foxglove.PoseInFrame": _object(
        "foxglove.PoseInFrame", "A timestamped pose for an object or reference frame in 3D space",
        timestamp=TIME, frame_id=STRING, pose=POSE),
    "foxglove.SceneUpdate": _object(
        "foxglove.SceneUpdate", "An update to the entities displayed in a 3D scene", deletions=ARRAY,
        entities={"type": "array", "items": _object(
            "foxglove.SceneEntity", "A visual element in a 3D scene", timestamp=TIME, frame_id=STRING, id=STRING,
            lifetime=DURATION, frame_locked=BOOLEAN, metadata=ARRAY, arrows=ARRAY,
            cubes={"type": "array", "items": CUBE}, spheres=ARRAY, cylinders=ARRAY, lines=ARRAY, triangles=ARRAY,
            texts={"type": "array", "items": TEXT}, models=ARRAY)}),
    "fvtree.NodeStatus": _object(
        "fvtree.NodeStatus", "a node of the behaviour tree changed status; `tree`: every node's status after it",
        timestamp=TIME, tick=TICK, node=STRING, status=STRING, feedback=STRING,
        tree={"type": "object", "additionalProperties": STRING}),
    "fvtree.FingerState": _object(
        "fvtree.FingerState", "one FingerVision finger's tactile state at a tick (force N, torque N m, from the "
                              "marker field; object area as a fraction of the image, centroid, orientation rad)",
        timestamp=TIME, tick=TICK, force=VECTOR3, torque=VECTOR3, slip=NUMBER,
        object=_object("fvtree.ObjectState", "the object seen through the skin", area=NUMBER,
                       centroid=_xyz("fvtree.Vector2", "image coordinates, normalised", "xy"),
                       orientation=NUMBER, present=BOOLEAN),
        healthy=BOOLEAN, valid_markers={**NUMBER, "description": "fraction of markers tracked"}),
    "fvtree.Wrench": _object("fvtree.Wrench", "force (N) and torque (N m) at the robot's tool", timestamp=TIME,
                             tick=TICK, force=VECTOR3, torque=VECTOR3),
    "fvtree.Gripper": _object("fvtree.Gripper", "gripper opening (m) and whether it holds an object",
                              timestamp=TIME, tick=TICK, width=NUMBER, object=BOOLEAN),
    "fvtree.LoadProfile": _object(
        "fvtree.LoadProfile", "a load scan along a plate: positions (m along the span), loads and smoothed loads "
                              "(marker displacement, px) and the chosen point",
        timestamp=TIME, tick=TICK, element=STRING, position=NUMBERS, load=NUMBERS, smoothed=NUMBERS,
        best_position=NUMBER, best_load=NUMBER),
}
