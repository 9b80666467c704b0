"""The per-finger records: frozen once made, with fresh default arrays, and made like dataclasses."""

import dataclasses

import numpy as np
import pytest

from perception.state import MarkerField, ObjectInfo, TactileState


@pytest.mark.parametrize("record", [MarkerField(), ObjectInfo(), TactileState("left", 0.0)])
def test_no_field_of_a_record_can_be_set(record):
    for f in dataclasses.fields(record):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(record, f.name, None)


def test_defaults_are_empty_and_not_shared():
    a, b = TactileState("left", 0.0), TactileState("right", 1.0)
    assert a.force is not b.force and a.obj is not b.obj and a.markers is not b.markers
    assert a.obj.centroid is not b.obj.centroid and a.markers.origin is not b.markers.origin
    assert a.force.shape == (3,) and a.obj.cells.shape == (3, 3) and a.markers.origin.shape == (0, 2)
    assert len(a.markers) == 0 and a.markers.valid.dtype == bool and a.healthy and a.health_reason == ""


def test_records_take_positional_and_keyword_fields_and_compare_as_dataclasses():
    origin = np.zeros((2, 2))
    markers = MarkerField(origin, origin + 1.0, np.ones(2), np.ones(2) * 2.0, np.ones(2, bool), (64, 48))
    named = MarkerField(origin=origin, position=origin + 1.0, origin_size=np.ones(2), size=np.ones(2) * 2.0,
                        valid=np.ones(2, bool), image_size=(64, 48))
    for f in dataclasses.fields(MarkerField):
        assert np.array_equal(getattr(markers, f.name), getattr(named, f.name))
    assert np.array_equal(markers.displacement, np.ones((2, 2))) and np.array_equal(markers.size_change, np.ones(2))
    state = TactileState("left", 2.0, markers, slip=0.1, healthy=False, health_reason="dark")
    assert dataclasses.replace(state, stamp=3.0).stamp == 3.0 and state.stamp == 2.0
    assert dataclasses.astuple(ObjectInfo(True, 0.2, np.ones(2), 0.3))[:2] == (True, 0.2)
    assert [f.name for f in dataclasses.fields(TactileState)] == [
        "finger", "stamp", "markers", "force", "torque", "obj", "slip", "healthy", "health_reason"]
