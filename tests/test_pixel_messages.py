"""Pixel mode's worker messages (`drivers.sim.models.pixel_messages`): frames and states come back
from their bytes equal field by field and bit for bit, and the marker map travels only when it is new;
a frame's JPEG comes back with its stamp."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from drivers.sim.models.pixel_messages import (
    StateDecoder,
    StateEncoder,
    decode_frame,
    decode_jpeg,
    encode_frame,
    encode_jpeg,
)
from perception.state import MarkerField, ObjectInfo, TactileState


def _same(a, b, where: str = "state") -> None:
    """Every field equal, bit for bit, with the same types (nested dataclasses, arrays, scalars)."""
    if dataclasses.is_dataclass(a):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            _same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert a.tobytes() == b.tobytes(), where
    else:
        assert type(a) is type(b) and (a == b or (math.isnan(a) and math.isnan(b))), (where, a, b)


def _state(rng: np.random.Generator, origin: np.ndarray, origin_size: np.ndarray, stamp: float,
           reason: str = "") -> TactileState:
    n = len(origin)
    markers = MarkerField(origin, origin + rng.normal(0, 1.0 / 3.0, (n, 2)), origin_size,
                          origin_size + rng.normal(0, 0.1, n), rng.random(n) > 0.2, (320, 240))
    obj = ObjectInfo(True, float(rng.random()), rng.normal(0, 0.1, 2), float(rng.normal()), rng.random((3, 3)),
                     rng.random((3, 3)))
    return TactileState("right", stamp, markers, rng.normal(size=3), rng.normal(size=3), obj,
                        float(rng.random() / 7.0), not reason, reason)


def test_a_state_comes_back_bit_for_bit_and_its_marker_map_only_when_new():
    rng = np.random.default_rng(5)
    origin, size = rng.uniform(0, 320, (37, 2)), np.full(37, 9.0) + rng.normal(0, 0.3, 37)
    encoder, decoder = StateEncoder(), StateDecoder("right")
    first, second = _state(rng, origin, size, 1 / 30), _state(rng, origin, size, 2 / 30, "only 46 % tracked – µ")
    sent = [encoder.encode(first), encoder.encode(second)]
    got = [decoder.decode(memoryview(b"s" + data)[1:]) for data in sent]  # as the worker's reply carries it
    _same(first, got[0])
    _same(second, got[1])
    assert len(sent[1]) < len(sent[0])  # the second leaves the map out ...
    assert got[1].markers.origin is got[0].markers.origin  # ... and shares the first's, as in one process
    grown = np.concatenate([origin, [[10.0, 20.0]]]), np.concatenate([size, [8.5]])  # a late marker joined
    third = _state(rng, *grown, 3 / 30)
    _same(third, decoder.decode(encoder.encode(third)))


def test_a_frame_comes_back_with_what_the_renderer_reads():
    rng = np.random.default_rng(6)
    position, size = rng.uniform(0, 320, (37, 2)), rng.uniform(8, 10, 37)
    obj = ObjectInfo(True, np.float64(0.3386515345551961), np.array([0.01, -0.2]), 0.25)
    got = decode_frame(encode_frame(position, size, obj, 1.5, 0.1))
    assert got[0].tobytes() == position.tobytes() and got[1].tobytes() == size.tobytes()
    assert (got[2].present, got[2].area, got[2].orientation) == (True, obj.area, 0.25)
    assert got[2].centroid.tobytes() == obj.centroid.tobytes() and got[3:] == (1.5, 0.1)
    assert decode_frame(encode_frame(position, size, None, 0.0, 0.2))[2] is None
    assert decode_frame(encode_frame(position, size, ObjectInfo(), 0.0, 0.2))[2].present is False


def test_a_jpeg_comes_back_with_its_stamp_and_none_without_one():
    jpeg = bytes(range(256)) * 40
    assert decode_jpeg(memoryview(encode_jpeg(jpeg, 1 / 3))) == (jpeg, 1 / 3)
    assert decode_jpeg(encode_jpeg(None, 0.2)) is None
