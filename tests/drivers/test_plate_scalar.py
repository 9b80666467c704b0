"""The beam plate's one-position path (Python floats, asked a few times a tick) gives the array
path's load bit for bit, inside and outside the span, and a float."""

import numpy as np
import pytest

from drivers.sim.models.plate import BeamPlate


@pytest.mark.parametrize("plate", [BeamPlate(), BeamPlate(span=1.3, EI=37.0, w=80.0, P=55.0, c=0.3, k=1500.0)])
def test_one_position_matches_the_array_path_bit_for_bit(plate):
    rng = np.random.default_rng(11)
    a = np.concatenate([rng.uniform(-0.2, plate.span + 0.2, 20000), [0.0, plate.span, plate.c, -0.0]])
    clearance = rng.uniform(-0.02, 0.05, len(a))
    one = np.array([plate.carried_force(float(x), float(g)) for x, g in zip(a, clearance)])
    array = np.array([plate.carried_force(np.asarray(x), np.asarray(g)) for x, g in zip(a, clearance)])
    np.testing.assert_array_equal(one, array)
    assert (one > 0).sum() > 1000 and (one == 0).sum() > 1000  # loaded and unloaded elements both seen
    assert isinstance(plate.carried_force(np.float64(0.4), np.float64(0.01)), float)  # numpy scalars too
    assert np.isnan(plate.carried_force(float("nan"), 0.0))
