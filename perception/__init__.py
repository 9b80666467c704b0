"""FingerVision perception: camera frames in, one `TactileState` per finger per frame out."""

from perception.state import FINGERS, MarkerField, ObjectInfo, TactileState

__all__ = ["FINGERS", "MarkerField", "ObjectInfo", "TactileState"]
