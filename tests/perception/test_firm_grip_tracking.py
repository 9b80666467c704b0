"""Markers under a firm grip stay tracked while they are in view: a marker grown by the press keeps
its dark-ring check (the ring moves out with its rim), a gel bent more sharply than one affine map
follows keeps its markers consistent (the tolerance grows with the displacement), and markers that
jumped further in one frame than the window reaches are re-acquired on the nearest marker-like blob
(`tracker.reacquire`). Before, such frames (every marker plainly in view) fell under the
supervisor's 50 % and stopped the demos (assembly_heavy's scan of P3, classify_substance's stir)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from conftest import match

from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.models.synthetic_camera import Appearance, SyntheticFingerVision
from perception import marker_tracking
from perception.config import load_config
from perception.fingervision import FingerVision
from perception.marker_tracking import WindowTracker
from perception.sensor_profile import load_profile
from perception.state import ObjectInfo

LOOK = Appearance(noise=2.0)
OBJECT = ObjectInfo(True, 0.3, np.array([0.5, 0.45]), 0.0)  # a dark-speckled object behind the skin


def firm_press(reacquire: float, peak: float = 90.0) -> tuple[list[float], list[float]]:
    """Tracked share and the largest error of a trusted marker (px) per frame of an off-centre press
    ramped to `peak` N (with 0.4 of it in shear) over a textured object, then held: markers move up
    to ~23 px and grow ~27 % (the calibrated profile's gains)."""
    model = SensorModel("right", load_profile("fingervision_default"), noise_px=0.0)
    camera = SyntheticFingerVision(model.origin, model.marker_size, seed=3)
    fv = FingerVision(load_config("fast", proximity__enabled=False, tracker__reacquire=reacquire), "right")
    fv.calibrate([camera.render(appearance=LOOK).image for _ in range(10)])
    idx = match(fv.marker_map.origin, model.origin)
    shares, errors = [], []
    for load in [*np.linspace(0.0, peak, 40), *[peak] * 15]:
        contact = FingerContact(normal=load, shear=np.array([0.4, 0.1]) * load, centre=np.array([150.0, 110.0]))
        field = model.state(contact, 0.0).markers
        frame = camera.render(field.position, field.size, obj=OBJECT, appearance=LOOK)
        assert frame.truth.visible.mean() > 0.8  # most markers are in view (a few pushed past the rim)
        state = fv.process(frame.image, 0.0)
        ok = state.markers.valid
        shares.append(float(ok.mean()))
        errors.append(float(np.linalg.norm(state.markers.position[ok] - frame.truth.position[idx][ok], axis=1).max()))
    return shares, errors


def test_a_firm_press_over_a_textured_object_keeps_its_markers_tracked():
    shares, errors = firm_press(0.45)
    assert min(shares) >= 0.6  # 68 % at the held peak
    assert max(errors) < 1.0  # and none of them caught on a wrong blob


def test_before_the_tracker_followed_grown_and_bent_markers_the_same_press_fell_under_half(monkeypatch):
    monkeypatch.setattr(marker_tracking, "GROWTH", 1.0)
    monkeypatch.setattr(marker_tracking, "SLACK", 0.0)
    shares, _ = firm_press(0.0)
    assert min(shares) < 0.5  # the supervisor's limit: 42 % measured


@pytest.mark.parametrize("reacquire, tracked", [(0.45, True), (0.0, False)])
def test_a_skin_that_jumped_further_than_the_window_reaches_is_reacquired(scene, reacquire, tracked):
    # A knock: the whole skin 13 px off in one frame (the window reaches ~8 px, the jump gate 5): no
    # marker is measured where it was, so its neighbours cannot say where it went.
    frame = scene.camera.render(appearance=scene.look)
    cfg = load_config("fast", tracker__reacquire=reacquire).tracker
    tracker = WindowTracker(cfg, scene.model.origin, frame.truth.size)
    tracker.step(frame.image, cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY))
    frame = scene.camera.render(scene.model.origin + [11.0, -7.0], appearance=scene.look)
    result = tracker.step(frame.image, cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY))
    inside = frame.truth.visible
    if tracked:
        assert result.valid[inside].mean() >= 0.9
        error = np.linalg.norm(result.position - frame.truth.position, axis=1)[result.valid]
        assert error.max() < 1.0
    else:
        assert result.valid.mean() < 0.5


def test_a_dark_spot_near_a_lost_marker_is_not_taken_for_it(scene):
    # One marker hidden under a dark square while its neighbours stay: the re-acquisition finds the
    # square's corner blobs or nothing, and its neighbours' stillness rejects any of them.
    frame = scene.camera.render(appearance=scene.look)
    tracker = WindowTracker(load_config("fast").tracker, scene.model.origin, frame.truth.size)
    tracker.step(frame.image, cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY))
    image = frame.image.copy()
    k = 18
    x, y = frame.truth.position[k]
    cv2.rectangle(image, (int(x - 8), int(y - 8)), (int(x + 8), int(y + 8)), (255, 255, 255), -1)
    cv2.circle(image, (int(x + 10), int(y + 3)), 4, (15, 15, 15), -1)  # a marker-like dark dot 10 px off
    for _ in range(5):
        result = tracker.step(image, cv2.cvtColor(image, cv2.COLOR_BGR2GRAY))
        assert not result.valid[k]
        assert np.delete(result.valid, k).all()
