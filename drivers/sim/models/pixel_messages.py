"""Pixel mode's messages between the main process and a fingertip worker, as flat bytes instead of
pickles: a frame's inputs and a `TactileState` each travel as one float64 buffer (a pickle of the
state's eleven arrays costs ~100 us a tick to write and read; this a tenth of it), exact to the bit;
the JPEG of a worker's newest frame travels as its stamp and its bytes.

The marker map's origin and sizes change only when the map grows, so a state carries them only
then; the receiving end reuses its copy, which keeps one origin array for every state of a map as
in one process (the recorder and the wrench cache key on it).
"""

from __future__ import annotations

import numpy as np

from perception.state import MarkerField, ObjectInfo, TactileState

_FRAME_HEAD = 8  # stamp, shift, object given, present, area, orientation, centroid x, y
_STATE_HEAD = 12  # markers, stamp, W, H, present, area, orientation, slip, healthy, new map, reason bytes, spare
_STATE_FIXED = 2 + 9 + 9 + 3 + 3  # centroid, cells, motion cells, force, torque


def encode_frame(position: np.ndarray, size: np.ndarray, obj: ObjectInfo | None, shift: float, stamp: float) -> bytes:
    """A frame's inputs: marker positions (N, 2) and sizes (N,), the object (what the renderer reads
    of it: presence, area, centroid, orientation), its slip shift and the stamp."""
    head = [stamp, shift, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    if obj is not None:
        head[2:] = 1.0, float(obj.present), obj.area, obj.orientation, *np.asarray(obj.centroid, float)
    return b"".join((np.array(head).tobytes(), np.ascontiguousarray(position, float).tobytes(),
                     np.ascontiguousarray(size, float).tobytes()))


def decode_frame(data: bytes | memoryview) -> tuple[np.ndarray, np.ndarray, ObjectInfo | None, float, float]:
    """(position, size, object, shift, stamp) of `encode_frame`'s bytes."""
    values = np.frombuffer(data, float)
    stamp, shift, given, present, area, orientation = values[:6].tolist()
    n = (len(values) - _FRAME_HEAD) // 3
    obj = ObjectInfo(bool(present), area, values[6:8].copy(), orientation) if given else None
    position = values[_FRAME_HEAD:_FRAME_HEAD + 2 * n].reshape(n, 2).copy()
    return position, values[_FRAME_HEAD + 2 * n:].copy(), obj, shift, stamp


def encode_jpeg(jpeg: bytes | None, stamp: float) -> bytes:
    """A frame's JPEG (None: no frame yet, or it could not be encoded) and its stamp."""
    return np.float64(stamp).tobytes() + (jpeg or b"")


def decode_jpeg(data: bytes | memoryview) -> tuple[bytes, float] | None:
    """(JPEG, stamp) of `encode_jpeg`'s bytes, or None when they carry no JPEG."""
    jpeg = bytes(data[8:])
    return (jpeg, float(np.frombuffer(data, float, 1)[0])) if jpeg else None


class StateEncoder:
    """A worker's end: states to bytes, the marker map only when it is not the one sent last."""

    def __init__(self):
        self._sent: tuple[np.ndarray, np.ndarray] | None = None

    def encode(self, state: TactileState) -> bytes:
        m, obj = state.markers, state.obj
        new_map = self._sent is None or self._sent[0] is not m.origin or self._sent[1] is not m.origin_size
        self._sent = (m.origin, m.origin_size)
        reason = state.health_reason.encode()
        head = [len(m), state.stamp, *m.image_size, obj.present, obj.area, obj.orientation, state.slip,
                state.healthy, new_map, len(reason), 0.0]
        parts = [head, obj.centroid, obj.cells, obj.motion_cells, state.force, state.torque,
                 m.position, m.size, m.valid]
        if new_map:
            parts += [m.origin, m.origin_size]
        return np.concatenate([np.ravel(p) for p in parts], dtype=float).tobytes() + reason


class StateDecoder:
    """The main process's end: bytes to a state of `finger`, equal to the worker's field by field."""

    def __init__(self, finger: str):
        self.finger = finger
        self._map: tuple[np.ndarray, np.ndarray] | None = None

    def decode(self, data: bytes | memoryview) -> TactileState:
        head = np.frombuffer(data, float, _STATE_HEAD).tolist()
        n, stamp, w, h, present, area, orientation, slip, healthy, new_map, reason_bytes, _ = head
        n, floats = int(n), len(data) - int(reason_bytes)
        values = np.frombuffer(data, float, floats // 8 - _STATE_HEAD, _STATE_HEAD * 8).copy()
        fixed = values[:_STATE_FIXED]
        at = _STATE_FIXED
        position = values[at:at + 2 * n].reshape(n, 2)
        size = values[at + 2 * n:at + 3 * n]
        valid = values[at + 3 * n:at + 4 * n] != 0.0
        if new_map:
            self._map = (values[at + 4 * n:at + 6 * n].reshape(n, 2), values[at + 6 * n:at + 7 * n])
        origin, origin_size = self._map
        obj = ObjectInfo(bool(present), area, fixed[:2], orientation, fixed[2:11].reshape(3, 3),
                         fixed[11:20].reshape(3, 3))
        markers = MarkerField(origin, position, origin_size, size, valid, (int(w), int(h)))
        return TactileState(self.finger, stamp, markers, fixed[20:23], fixed[23:26], obj, slip, bool(healthy),
                            bytes(data[floats:]).decode())
