"""Real FingerVision footage (akihikoy/fingervision fv_demo, GPL-3.0, kept outside the repository):
markers are found, tracked across the whole clip, and never jump."""

import numpy as np
import pytest
from conftest import REAL_CLIP

from perception.config import load_config
from perception.fingervision import FingerVision
from perception.frames import read_clip

pytestmark = pytest.mark.skipif(not REAL_CLIP.is_file(),
                                reason=f"real footage not found at {REAL_CLIP} (../shared/data/fv_demo)")


@pytest.fixture(scope="module")
def frames():
    return read_clip(REAL_CLIP, None)


def test_markers_are_tracked_across_the_clip_without_jumps(frames):
    assert len(frames) > 2000
    fv = FingerVision(load_config("fast", proximity__enabled=False), "right")
    marker_map = fv.calibrate(frames[:10])
    assert len(marker_map) >= 20
    tracked, jumps, prev, frozen = [], 0, None, []
    for k, frame in enumerate(frames):
        state = fv.process(frame, k / 54.0)
        if "frozen" in state.health_reason:
            frozen.append(k)
        m = state.markers
        tracked.append(m.valid.mean())
        if prev is not None:
            n = len(prev)  # markers added after calibration are appended: compare the ones before
            both = m.valid[:n] & prev.valid
            # A tracked marker cannot move 3 px more than its own field's median in one frame.
            step = m.position[:n] - prev.position
            rel = np.linalg.norm(step - np.median(step[both], axis=0), axis=1) if both.any() else step[:, 0]
            jumps += int((rel[both] > 3.0).sum())
        prev = m
    assert not frozen, f"frames {frozen[:5]} flagged frozen: the codec's still blocks are no frozen camera"
    assert np.median(tracked) >= 0.9
    assert np.percentile(tracked, 5) >= 0.75
    assert jumps <= 0.0005 * len(frames) * len(marker_map)  # at most a handful in ~80k marker-frames
    # The lattice marker half hidden by the dark object in the first frames is added once plain
    # (checked by eye on a 3x overlay of frame 344), and nothing else.
    added = fv.marker_map.origin[len(marker_map):]
    assert len(added) == 1 and np.linalg.norm(added[0] - REAL_LATE) < 2.0


# The 28 markers of the clip's first frame, checked by eye on an overlay of the calibrated map at 3x
# (each circle on a black dot of the marker lattice; none on the white bar, the brown smudge or the
# dark spots of the object behind the skin).
REAL_MARKERS = np.array([
    (25, 9), (204, 18), (142, 19), (86, 22), (258, 25), (40, 31), (301, 36), (13, 43), (142, 77), (207, 78),
    (80, 78), (307, 84), (309, 140), (80, 141), (140, 144), (205, 144), (9, 181), (301, 190), (38, 191),
    (261, 199), (83, 200), (143, 205), (203, 205), (23, 218), (289, 229), (34, 82), (31, 138), (265, 142)], float)
REAL_LATE = np.array([264.0, 81.0])


def test_calibration_finds_the_real_markers_and_nothing_on_the_background(frames):
    marker_map = FingerVision(load_config("fast", proximity__enabled=False), "right").calibrate(frames[:10])
    assert len(marker_map) >= 28
    d = np.linalg.norm(marker_map.origin[:, None, :] - REAL_MARKERS[None, :, :], axis=2)
    assert d.min(axis=1).max() < 2.0, "a calibrated marker lies off the marker lattice"


def test_original_preset_calibrates_as_the_2018_code(frames):
    # The 2018 rule keeps a marker lost in a calibration frame and drops it for drift only: the
    # original code keeps 23 markers on this clip (dark background spots among them, as it did).
    marker_map = FingerVision(load_config("original", proximity__enabled=False), "right").calibrate(frames[:10])
    assert len(marker_map) == 23
