"""Marker detection, calibration and tracking on rendered frames with known ground truth."""

import dataclasses

import cv2
import numpy as np
import pytest
from conftest import Scene, match

from perception.calibration import CalibrationError, MarkerMap, calibrate_markers
from perception.config import TrackerConfig, load_config
from perception.detect import BlobDetector, ComponentDetector, marker_mask
from perception.marker_tracking import AssignTracker, WindowTracker, inconsistent


@pytest.mark.parametrize("preset, overrides", [
    ("fast", {}),
    ("fast", {"kalman__enabled": False}),
    ("original", {}),
    ("original", {"tracker__kind": "assign", "detector__kind": "cc"}),
])
def test_tracked_positions_match_ground_truth_at_noise_4(preset, overrides):
    scene = Scene(noise=4.0)
    fv = scene.pipeline(preset, proximity__enabled=False, **overrides)
    idx = match(fv.marker_map.origin, scene.model.origin)
    assert len(idx) >= 0.9 * len(scene.model.origin)
    errors, tracked = [], []
    for image, truth in scene.press(frames=40):
        state = fv.process(image, 0.0)
        ok = state.markers.valid
        errors.append(state.markers.position[ok] - truth.position[idx][ok])
        tracked.append(ok.mean())
    rms = np.sqrt((np.concatenate(errors) ** 2).sum(axis=1).mean())
    limit = 0.2 if preset == "fast" else 0.3
    assert rms < limit
    assert min(tracked) > 0.95


def test_both_detectors_find_every_rendered_marker_with_subpixel_centres():
    scene = Scene(noise=2.0)
    frame = scene.camera.render(scene.model.origin + [0.3, -0.4], appearance=scene.look)
    grey = cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY)
    for cfg, det in [(load_config("fast"), ComponentDetector), (load_config("original"), BlobDetector)]:
        blobs = det(cfg.detector).detect(marker_mask(frame.image, grey, cfg.threshold))
        d = np.linalg.norm(blobs.xy[:, None] - frame.truth.position[None], axis=2)
        assert (d.min(axis=0) < 0.5).mean() >= 0.95  # nearly every marker found, close to truth
    cc = ComponentDetector(load_config("fast").detector).detect(
        marker_mask(frame.image, grey, load_config("fast").threshold))
    d = np.linalg.norm(cc.xy[:, None] - frame.truth.position[None], axis=2).min(axis=0)
    assert np.median(d) < 0.15


def test_calibration_round_trip_through_yaml(tmp_path):
    scene = Scene()
    marker_map = calibrate_markers(scene.calibration(), load_config("fast"))
    path = tmp_path / "markers.yaml"
    marker_map.save(path)
    loaded = MarkerMap.load(path)
    np.testing.assert_allclose(loaded.origin, marker_map.origin, atol=1e-4)
    np.testing.assert_allclose(loaded.size, marker_map.size, atol=1e-4)
    assert loaded.image_size == (320, 240)
    fewer = loaded.without_near(loaded.origin[0], radius=5.0)
    assert len(fewer) == len(loaded) - 1


def test_calibration_drops_a_marker_that_moves_during_calibration():
    scene = Scene()
    frames = []
    for k in range(10):
        pos = scene.model.origin.copy()
        pos[5] += [0.3 * k, 0.0]  # a bead drifting in the gel
        frames.append(scene.camera.render(pos, appearance=scene.look).image)
    marker_map = calibrate_markers(frames, load_config("fast"))
    assert np.linalg.norm(marker_map.origin - scene.model.origin[5], axis=1).min() > 5.0
    assert len(marker_map) == len(scene.model.origin) - 1


@pytest.mark.parametrize("frames, message", [
    ([np.full((240, 320, 3), 200, np.uint8)] * 10, "found 0 markers"),
    ([np.zeros((240, 320, 3), np.uint8)], "at least 2 frames"),
    ([np.zeros((240, 320), np.float32)] * 3, "bad calibration frame"),
])
def test_calibration_failures_say_what_to_check(frames, message):
    with pytest.raises(CalibrationError, match=message):
        calibrate_markers(frames, load_config("fast"))


def test_marker_map_load_rejects_other_files(tmp_path):
    path = tmp_path / "other.yaml"
    path.write_text("name: not a marker map\n")
    with pytest.raises(CalibrationError, match="not a marker map"):
        MarkerMap.load(path)


def two_markers_one_blob(cfg):
    """A calibrated tracker's view of a frame where two neighbours' blobs sit on one spot."""
    scene = Scene(noise=1.0)
    marker_map = calibrate_markers(scene.calibration(), cfg)
    idx = match(marker_map.origin, scene.model.origin)
    i, j = 0, 1  # neighbours on the top row of the calibrated map
    pos = scene.model.origin.copy()
    pos[idx[i]] = pos[idx[j]] = 0.5 * (pos[idx[i]] + pos[idx[j]])  # both blobs on one place
    frame = scene.camera.render(pos, appearance=scene.look)
    predicted = marker_map.origin.copy()
    predicted[i] = predicted[j] = pos[idx[i]] + [0.5, 0.0]
    grey = cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY)
    return marker_map, frame.image, grey, predicted, (i, j)


def test_window_tracker_flags_two_markers_on_one_blob():
    cfg = load_config("fast")
    marker_map, image, grey, predicted, (i, j) = two_markers_one_blob(cfg)
    tracker = WindowTracker(cfg.tracker, marker_map.origin, marker_map.size)
    _, _, ok = tracker._measure(image, grey, predicted, marker_map.size)
    assert not ok[i] and not ok[j]
    assert ok[2:].all()


def test_assign_tracker_gives_a_blob_to_one_marker_only():
    cfg = load_config("original").with_overrides({"detector.kind": "cc"})
    marker_map, image, grey, predicted, (i, j) = two_markers_one_blob(cfg)
    tracker = AssignTracker(cfg.tracker, cfg.threshold, ComponentDetector(cfg.detector),
                            marker_map.origin, marker_map.size)
    _, _, ok = tracker._measure(image, grey, predicted, marker_map.size)
    assert ok[i] != ok[j]
    assert ok[2:].all()


def test_consistency_check_flags_a_marker_that_leaves_its_neighbours():
    origin = np.array([[x, y] for y in (0.0, 30.0, 60.0) for x in (0.0, 30.0, 60.0)])
    disp = np.tile([1.0, 0.5], (9, 1))
    disp[4] = [8.0, 0.5]  # the centre marker claims something 7 px away
    from perception.marker_tracking import neighbour_index
    flagged = inconsistent(disp, np.ones(9, bool), neighbour_index(origin, 4), tolerance=3.0)
    assert flagged.tolist() == [False] * 4 + [True] + [False] * 4


def test_lost_markers_are_reset_to_their_origin_after_repeated_failures():
    scene = Scene(noise=1.0)
    cfg = dataclasses.replace(TrackerConfig(), n_reset=3)
    tracker = WindowTracker(cfg, scene.model.origin, np.full(len(scene.model.origin), 9.0))
    blank = np.full((240, 320, 3), 180, np.uint8)
    grey = blank[:, :, 0].copy()
    tracker.position += 2.0  # as if the markers had moved before they vanished
    restarted = [tracker.step(blank, grey).restarted.all() for _ in range(5)]
    assert restarted == [False, False, False, False, True]
    np.testing.assert_allclose(tracker.position, scene.model.origin)
