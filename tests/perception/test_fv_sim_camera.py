"""The synthetic FingerVision camera: truth matches the pixels, seeded, and the pixel-level cell hook."""

import cv2
import numpy as np
import pytest

from drivers.clock import SimClock
from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.models.synthetic_camera import Appearance, SyntheticFingerVision, pixel_level_sense
from perception.state import FINGERS, ObjectInfo


def test_rendered_marker_centres_are_the_ground_truth_to_a_few_hundredths_of_a_pixel():
    model = SensorModel("left", noise_px=0.0)
    cam = SyntheticFingerVision(model.origin, clutter=0, seed=1)
    shifted = model.origin + np.array([0.37, -0.21])
    frame = cam.render(shifted, appearance=Appearance(noise=0.0))
    grey = cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY).astype(float)
    for (x, y) in frame.truth.position[frame.truth.visible][:10]:
        x0, y0 = int(round(x)) - 7, int(round(y)) - 7
        patch = grey[y0:y0 + 15, x0:x0 + 15]
        w = np.clip(np.median(patch) - patch - 20.0, 0, None)  # darkness of the marker pixels only
        ys, xs = np.mgrid[0:15, 0:15]
        assert (w * xs).sum() / w.sum() + x0 == pytest.approx(x, abs=0.03)
        assert (w * ys).sum() / w.sum() + y0 == pytest.approx(y, abs=0.03)


def test_same_seed_same_frames_other_seed_other_noise():
    origin = SensorModel("right").origin
    a = [SyntheticFingerVision(origin, seed=5).render().image for _ in range(2)]
    b = SyntheticFingerVision(origin, seed=5).render().image
    c = SyntheticFingerVision(origin, seed=6).render().image
    assert np.array_equal(a[0], b) and not np.array_equal(a[0], c)


def test_occlusion_and_glare_hide_markers_in_the_truth():
    origin = SensorModel("right").origin
    cam = SyntheticFingerVision(origin, seed=2)
    assert cam.render().truth.visible.all()
    for look in (Appearance(occlusion=0.3), Appearance(glare=0.3)):
        hidden = (~cam.render(appearance=look).truth.visible).mean()
        assert 0.1 < hidden < 0.6


def test_object_truth_matches_the_requested_pose():
    cam = SyntheticFingerVision(SensorModel("right").origin, seed=2)
    obj = ObjectInfo(True, 0.2, np.array([0.05, -0.04]), 0.6)
    truth = cam.render(obj=obj).truth.obj
    assert truth.area == pytest.approx(0.2, rel=0.02)
    np.testing.assert_allclose(truth.centroid, obj.centroid, atol=0.005)
    assert truth.orientation == pytest.approx(0.6, abs=0.02)


def test_positions_must_match_the_marker_layout():
    cam = SyntheticFingerVision(SensorModel("right").origin)
    with pytest.raises(ValueError, match="positions have shape"):
        cam.render(np.zeros((3, 2)))


class PressingWorld:
    """A world whose fingertips are squeezed harder every tick, with the element in view."""

    def __init__(self):
        self.ticks = 0

    def contacts(self):
        self.ticks += 1
        load = min(60.0, 4.0 * self.ticks)
        view = ObjectInfo(True, 0.3, np.zeros(2), 0.0)
        return {f: FingerContact(load, np.array([0.0, 0.2 * load]), 0.0, None, view) for f in FINGERS}


def test_pixel_level_sense_runs_the_real_pipeline_on_rendered_frames():
    clock = SimClock(1.0 / 30.0)
    sensors = {f: SensorModel(f, seed=i) for i, f in enumerate(FINGERS)}
    sense = pixel_level_sense(PressingWorld(), sensors, clock, seed=4)
    states = []
    for _ in range(20):
        clock.advance()
        states.append(sense())
    last = states[-1]
    assert set(last) == set(FINGERS)
    assert all(s.healthy and s.stamp == pytest.approx(clock.now()) for s in last.values())
    assert last["right"].force[1] < -0.5 < 0.5 < last["left"].force[1]  # squeezed from both sides
    assert last["left"].obj.present and last["right"].obj.present
    assert last["left"].markers.valid.mean() > 0.9
