"""The shortcuts that make the simulated cell and the recorder cheaper give the same values, bit for bit, as
the general path: an unloaded fingertip's shared rest field, and the recorder's marker arrows built per batch."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from perception.state import ObjectInfo


def _contacts() -> list[FingerContact]:
    """Unloaded ticks around loaded ones (some with the object in view), past one random-number block."""
    unloaded = [FingerContact() for _ in range(150)]
    seen = ObjectInfo(True, 0.2, np.array([0.1, -0.05]), 0.3)
    loaded = [FingerContact(2.0 + 0.1 * i, np.array([0.3 * i, -0.2]), 0.001 * i, None, seen, 0.01 * i)
              for i in range(5)]
    sideways = [FingerContact(0.0, np.array([-0.0, 0.0]), 0.0, None, seen, 0.02)]  # no load, the object in view
    return unloaded + loaded + sideways * 3 + unloaded + loaded[:2]


def _same(a, b) -> None:
    for x, y in ((a.markers.position, b.markers.position), (a.markers.size, b.markers.size),
                 (a.markers.valid, b.markers.valid), (a.force, b.force), (a.torque, b.torque),
                 (a.obj.centroid, b.obj.centroid)):
        assert np.array_equal(x, y)
    assert (a.slip, a.obj.present, a.obj.area, a.obj.orientation) == (b.slip, b.obj.present, b.obj.area,
                                                                         b.obj.orientation)


@pytest.mark.parametrize("errors", [True, False])
def test_an_unloaded_fingertip_gives_the_states_of_the_general_path(errors):
    shortcut = SensorModel("left", seed=3, pipeline_errors=errors)
    general = SensorModel("left", seed=3, pipeline_errors=errors)
    general._exact = general._loaded  # every tick through the product with the contact basis
    states = []
    for k, contact in enumerate(_contacts()):
        a, b = shortcut.state(contact, 0.01 * k), general.state(contact, 0.01 * k)
        _same(a, b)
        states.append(a)
    assert states[0].markers.position is not states[1].markers.position  # never one array handed out twice
    assert not np.array_equal(states[0].markers.position, states[1].markers.position)  # noise on the rest field
