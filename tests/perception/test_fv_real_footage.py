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
    tracked, jumps, prev = [], 0, None
    for k, frame in enumerate(frames):
        state = fv.process(frame, k / 54.0)
        m = state.markers
        tracked.append(m.valid.mean())
        if prev is not None:
            both = m.valid & prev.valid
            # A tracked marker cannot move 3 px more than its own field's median in one frame.
            step = m.position - prev.position
            rel = np.linalg.norm(step - np.median(step[both], axis=0), axis=1) if both.any() else step[:, 0]
            jumps += int((rel[both] > 3.0).sum())
        prev = m
    assert np.median(tracked) >= 0.9
    assert np.percentile(tracked, 5) >= 0.75
    assert jumps <= 0.0005 * len(frames) * len(marker_map)  # at most a handful in ~80k marker-frames
