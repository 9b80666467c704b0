"""Markers missed at calibration and added later (`perception.late_markers`): a covered marker that
is uncovered gets a new, stable index; dark objects, moving or resting, and textures never make one."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from assembly.bench.perception.scenes import StressBench
from drivers.sim.models.synthetic_camera import Appearance
from perception.calibration import MarkerMap
from perception.config import ConfigError, load_config
from perception.fingervision import FingerVision
from perception.learning.blobmoves import LogError, import_logs, read_trial
from perception.learning.features import tick_features
from perception.state import TactileState

LOOK = Appearance(noise=2.0)
COVERED = Appearance(noise=2.0, occlusion=0.12)  # a dark object over about 13 of the 61 markers


def pipeline(**overrides) -> FingerVision:
    return FingerVision(load_config("fast", **{"proximity__enabled": False, **overrides}))


def nearest(origin: np.ndarray, truth: np.ndarray) -> np.ndarray:
    return np.linalg.norm(origin[:, None] - truth[None], axis=2).min(axis=1)


def test_an_uncovered_marker_is_added_with_a_new_stable_index():
    bench = StressBench(0)
    fv = pipeline()
    fv.calibrate([bench.plain.render(appearance=COVERED).image for _ in range(10)])
    calibrated = fv.marker_map
    n0 = len(calibrated)
    assert n0 < len(bench.origin) - 8  # the covered ones are missing
    states = [fv.process(bench.plain.render(appearance=LOOK).image, k / 30) for k in range(150)]
    grown = fv.marker_map
    assert len(grown) > n0 + 8
    # Existing indices never renumber: the first n0 rows are the calibrated map, unchanged.
    np.testing.assert_array_equal(grown.origin[:n0], calibrated.origin)
    np.testing.assert_array_equal(grown.size[:n0], calibrated.size)
    # Every added marker is a true one, at its rest position, and none twice.
    assert nearest(grown.origin[n0:], bench.origin).max() < 0.3
    d = np.linalg.norm(grown.origin[:, None] - grown.origin[None], axis=2)
    np.fill_diagonal(d, np.inf)
    assert d.min() > 15.0
    # Identity is stable: each added index keeps its origin and is tracked from then on.
    first = next(k for k, s in enumerate(states) if len(s.markers) > n0)
    one = n0  # the first added marker
    origin = states[first].markers.origin[one]
    for s in states[first:]:
        np.testing.assert_array_equal(s.markers.origin[one], origin)
        assert s.markers.valid[one]
        assert np.linalg.norm(s.markers.position[one] - origin) < 0.3
    last = fv.process(bench.plain.render(appearance=LOOK).image, 3.0).markers
    assert last.valid.all() and len(last) == len(grown)
    # Downstream users take the grown field: the wrench stays near zero at rest, features keep their width.
    assert np.abs(states[-1].force).max() < 0.3
    left = TactileState("left", 0.0)
    assert tick_features(left, states[-1]).shape == tick_features(left, states[0]).shape


def test_markers_are_added_only_where_the_skin_is_at_rest():
    bench = StressBench(1)
    fv = pipeline()
    fv.calibrate([bench.plain.render(appearance=COVERED).image for _ in range(10)])
    n0 = len(fv.marker_map)
    shifted = bench.origin + np.array([3.0, 0.0])  # uncovered under a 3 px shear: origin unknown
    for k in range(60):
        fv.process(bench.plain.render(shifted, 9.0, appearance=LOOK).image, k / 30)
    assert len(fv.marker_map) == n0
    for k in range(90):  # released
        fv.process(bench.plain.render(appearance=LOOK).image, k / 30)
    assert len(fv.marker_map) > n0
    assert nearest(fv.marker_map.origin[n0:], bench.origin).max() < 0.3


@pytest.mark.parametrize("seed", [0, 1])
def test_dark_things_in_lattice_holes_never_become_markers(seed):
    """Three markers left out of the skin make three holes; a marker-sized dark disc crosses the first
    slowly (0.22 px per frame, measured as a candidate on its way), a dark texture square rests in
    the second and an object edge lies across the third."""
    bench = StressBench(seed)
    hidden = np.argsort(np.linalg.norm(bench.origin - [160, 120], axis=1))[[0, 8, 20]]
    position = bench.origin.copy()
    position[hidden] = -50.0  # drawn off the image
    fv = pipeline()
    fv.calibrate([bench.plain.render(position, 9.0, appearance=LOOK).image for _ in range(10)])
    n0 = len(fv.marker_map)
    assert n0 == len(bench.origin) - 3
    disc, square, edge = bench.origin[hidden]
    seen = []
    follow = fv._late._follow
    fv._late._follow = lambda *found: (seen.append(len(found[0])), follow(*found))[1]
    for k in range(300):
        img = bench.plain.render(position, 9.0, appearance=LOOK).image.copy()
        x, y = np.rint(disc + [-30 + 0.2 * k, -15 + 0.1 * k]).astype(int)  # over the hole at frame 150
        cv2.circle(img, (x, y), 4, (20, 20, 20), -1, cv2.LINE_AA)
        x, y = np.rint(square).astype(int)
        cv2.rectangle(img, (x - 4, y - 4), (x + 4, y + 4), (20, 20, 20), -1)
        x, y = np.rint(edge).astype(int)
        cv2.line(img, (x - 3, y - 12), (x + 3, y + 12), (20, 20, 20), 3)
        fv.process(img, k / 30)
    assert max(seen) == 1  # the disc was looked at as it crossed (the square and the edge never)
    assert len(fv.marker_map) == n0


@pytest.mark.parametrize("pattern", ["qr", "dark"])
def test_a_textured_or_dark_object_in_view_from_calibration_on_adds_no_false_marker(pattern):
    bench = StressBench(3, pattern, 0.4)
    fv = pipeline()
    fv.calibrate([bench.camera.render(appearance=LOOK).image for _ in range(10)])
    n0 = len(fv.marker_map)
    for k in range(120):
        fv.process(bench.camera.render(appearance=LOOK).image, k / 30)
    assert nearest(fv.marker_map.origin[n0:], bench.origin).max(initial=0.0) < 1.0


def test_late_markers_are_off_in_the_original_presets_and_checked():
    assert not load_config("original").late.enabled and not load_config("thesis").late.enabled
    with pytest.raises(ConfigError, match="late.confirm at least 2"):
        load_config("fast", late__confirm=1)


def test_a_grown_marker_map_saves_and_loads(tmp_path):
    m = MarkerMap(np.array([[10.0, 10.0], [40.0, 10.0]]), np.array([8.0, 9.0]), (64, 48))
    grown = m.appended(np.array([[25.0, 30.0]]), np.array([8.5]), np.array([0.02]))
    grown.save(tmp_path / "map.yaml")
    back = MarkerMap.load(tmp_path / "map.yaml")
    np.testing.assert_allclose(back.origin, [[10, 10], [40, 10], [25, 30]])
    np.testing.assert_allclose(back.ring, [0.0, 0.0, 0.02])


def test_a_blobmoves_log_with_a_marker_appended_later_imports(tmp_path):
    origins = [[40.0 + 30 * i, 60.0 + 20 * (i % 2)] for i in range(6)]
    moves = [[x, y, 8.0, 1.0, 0.0, 0.2] for x, y in origins]
    frames = [moves[:5]] * 3 + [moves] * 2  # the sixth marker found after the third frame
    path = tmp_path / "grown.json"
    path.write_text(json.dumps({"load": 2.0, "finger": "right", "frames": frames}))
    trial = read_trial(path)
    assert trial["markers"].shape == (5, 6, 6) and np.isnan(trial["markers"][:3, 5]).all()
    rec = import_logs([path])
    assert len(rec) == 5 and np.isfinite(rec.features).all()
    # Fewer markers than the frame before is still refused, naming the frame.
    path.write_text(json.dumps({"load": 2.0, "frames": [moves, moves, moves[:5]]}))
    with pytest.raises(LogError, match=r"frames\[2\]: 5 markers where the first frame has 6"):
        read_trial(path)
