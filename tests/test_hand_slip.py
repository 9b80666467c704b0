"""The slip a load scan judges: the pipeline's slip less what the markers' own motion explains,
compiled, with the same values as numpy."""

import numpy as np
import pytest

from behaviours.skill_kit.hand import slip_beyond_marker_flow
from perception.state import MarkerField, ObjectInfo, TactileState


def _state(position, valid, slip=0.5, present=True, area=0.2):
    origin = np.zeros_like(position)
    markers = MarkerField(origin, position, np.ones(len(position)), np.ones(len(position)), valid)
    return TactileState("left", 0.0, markers, obj=ObjectInfo(present, area), slip=slip)


def _numpy(now, before, gain, saturation):
    both = now.markers.valid & before.markers.valid
    distances = np.linalg.norm(now.markers.position - before.markers.position, axis=1)[both]
    return max(0.0, now.slip - gain * now.obj.area * min(float(np.add.reduce(distances)) / both.sum(), saturation))


@pytest.mark.parametrize("seed", range(5))
def test_the_slip_left_after_the_marker_flow_is_numpys(seed):
    rng = np.random.default_rng(seed)
    before = _state(rng.uniform(0, 300, (37, 2)), rng.random(37) < 0.8)
    now = _state(before.markers.position + rng.normal(0, 0.3, (37, 2)), rng.random(37) < 0.8)
    for gain, saturation in ((0.65, 1.0), (2.0, 0.1)):
        assert slip_beyond_marker_flow(now, before, gain, saturation) == pytest.approx(
            _numpy(now, before, gain, saturation), rel=1e-15, abs=0.0)


def test_nothing_is_explained_without_an_object_shared_markers_or_one_calibration():
    position = np.ones((4, 2))
    moved = _state(position + 1.0, np.ones(4, bool))
    assert slip_beyond_marker_flow(_state(position + 1.0, np.ones(4, bool), present=False),
                                   _state(position, np.ones(4, bool)), 0.65, 1.0) == 0.5
    assert slip_beyond_marker_flow(moved, _state(position, np.zeros(4, bool)), 0.65, 1.0) == 0.5
    assert slip_beyond_marker_flow(moved, _state(np.ones((5, 2)), np.ones(5, bool)), 0.65, 1.0) == 0.5
    assert slip_beyond_marker_flow(moved, _state(position, np.ones(4, bool)), 0.65, 1.0) == pytest.approx(
        0.5 - 0.65 * 0.2 * 1.0)
