"""The sensor profile: the default is the measured figures with their sources, the simulated sensor
follows it in both perception modes, cell files name it, and skills read it instead of constants."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drivers.cell_builders import load_cell
from drivers.cell_file import CellFileError
from drivers.sim.models.fingervision_model import FingerContact, SensorModel, layout_of
from perception.sensor_profile import NUMBERS, SensorProfileError, default_profile, load_profile

CLIP = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "fv_demo" / "cam1_0002.m4v"


def test_default_profile_holds_the_measured_figures_each_with_its_source():
    p = default_profile()
    assert (p.normal_px_per_n, p.rest_jitter_px, p.image_size) == (0.17, 0.067, (320, 240))
    assert p.shear_to_normal == pytest.approx(1.0)  # not the old simulator's 0.178 / 0.032 = 5.6
    assert set(p.sources) == set(NUMBERS)
    assert all(len(source) > 20 for source in p.sources.values())


def test_a_number_without_its_source_is_refused(tmp_path):
    bad = tmp_path / "p.yaml"
    bad.write_text("normal_px_per_n: 0.2\n")
    with pytest.raises(SensorProfileError, match="source") as info:
        load_profile(str(bad))
    assert (info.value.line, info.value.field) == (1, "normal_px_per_n")
    bad.write_text("normal_px_per_nn: {value: 0.2, source: here}\n")
    with pytest.raises(SensorProfileError, match="unknown field"):
        load_profile(str(bad))


@pytest.mark.parametrize("axis", ["normal", "shear"])
def test_simulated_markers_move_by_the_profiles_px_per_newton(axis):
    model = SensorModel("left", noise_px=0.0)
    load = 10.0
    contact = FingerContact(normal=load) if axis == "normal" else FingerContact(shear=np.array([load, 0.0]))
    moved = model.state(contact, 0.0).markers.position - model.origin
    mean = np.hypot(moved[:, 0], moved[:, 1]).mean() if axis == "normal" else moved[:, 0].mean()
    assert mean / load == pytest.approx(getattr(default_profile(), f"{axis}_px_per_n"), rel=1e-6)


def test_signals_mode_rest_jitter_is_the_profiles_median_step():
    model = SensorModel("right", seed=4, pipeline_errors=True)
    positions = np.array([model.state(FingerContact(), t / 30).markers.position for t in range(600)])
    valid = np.array([model.state(FingerContact(), t / 30).markers.valid for t in range(1)])[0]
    steps = np.hypot(*np.diff(positions, axis=0)[:, valid].reshape(-1, 2).T)
    assert np.median(steps) == pytest.approx(default_profile().rest_jitter_px, rel=0.08)


def test_both_modes_build_the_sensor_from_the_cells_profile():
    from drivers.sim.models.synthetic_camera import finger_rigs

    cell = load_cell("sim", 30.0, scene="press")
    try:
        profile = cell.sensor_profile
        assert profile == default_profile()
        rigs = finger_rigs({f: SensorModel(f, profile) for f in ("left", "right")}, cell.clock, 0, "fast")
        for rig in rigs.values():
            np.testing.assert_array_equal(rig.origin, layout_of(profile))
            assert rig.marker_size == profile.marker_diameter_px
    finally:
        cell.close()


def test_a_cell_file_names_its_profile_and_a_bad_name_says_where(tmp_path):
    profile = tmp_path / "mine.yaml"
    text = (Path(__file__).resolve().parents[1] / "perception" / "sensor_profiles" / "fingervision_default.yaml").read_text()
    profile.write_text(text.replace("value: 0.17\n  source: >-\n    public", "value: 0.5\n  source: >-\n    public", 1))
    cell_file = tmp_path / "cell.yaml"
    cell_file.write_text("kind: sim\nsensor:\n  profile: mine.yaml\n")
    cell = load_cell(str(cell_file), 30.0, scene="press")
    try:
        assert cell.sensor_profile.normal_px_per_n == 0.5
    finally:
        cell.close()
    cell_file.write_text("kind: sim\nsensor:\n  profile: nosuch\n")
    with pytest.raises(CellFileError, match="no such sensor profile") as info:
        load_cell(str(cell_file), 30.0, scene="press")
    assert info.value.field == "sensor.profile" and info.value.line == 3


@pytest.mark.skipif(not CLIP.exists(), reason=f"the real FingerVision clip is not at {CLIP}")
def test_profile_marker_size_and_spacing_match_the_real_clip():
    """How the profile's marker figures were measured: dark blobs (HSV V <= 42, 30-150 px^2, near
    round) on every 50th frame of the real clip; their bounding-box diameter and nearest-neighbour
    distance."""
    cv2 = pytest.importorskip("cv2")
    capture = cv2.VideoCapture(str(CLIP))
    diameters, spacings, frame = [], [], 0
    while True:
        ok, image = capture.read()
        if not ok:
            break
        frame += 1
        if frame % 50:
            continue
        mask = cv2.inRange(cv2.cvtColor(image, cv2.COLOR_BGR2HSV), (0, 0, 0), (180, 255, 42))
        n, _, stats, centres = cv2.connectedComponentsWithStats(mask)
        keep = [k for k in range(1, n) if 30 <= stats[k, 4] <= 150 and 0.6 < stats[k, 2] / stats[k, 3] < 1.6
                and stats[k, 4] / (stats[k, 2] * stats[k, 3]) > 0.55]
        diameters += [max(stats[k, 2], stats[k, 3]) for k in keep]
        points = centres[keep]
        if len(points) > 3:
            d = np.hypot(*(points[:, None] - points[None]).transpose(2, 0, 1))
            np.fill_diagonal(d, np.inf)
            spacings += d.min(axis=1).tolist()
    p = default_profile()
    assert np.percentile(diameters, 10) <= p.marker_diameter_px <= np.percentile(diameters, 90)
    # a flat lattice as dense as the clip's squashed rim (the profile's source says why), as many markers
    assert 0.95 * np.percentile(spacings, 10) <= p.marker_spacing_px <= np.median(spacings)
    assert 29 <= len(layout_of(p)) <= 31
