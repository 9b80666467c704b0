"""Force/torque conventions of the left and right fingers, normal modes and averaging."""

import numpy as np
import pytest

from perception.state import MarkerField
from perception.wrench import marker_forces, marker_levers, normal_component, wrench


def field(origin, position, size0=9.0, size=None, valid=None):
    origin = np.asarray(origin, float)
    position = np.asarray(position, float)
    n = len(origin)
    sizes = np.full(n, size0) if size is None else np.asarray(size, float)
    valid = np.ones(n, bool) if valid is None else np.asarray(valid, bool)
    return MarkerField(origin, position, np.full(n, size0), sizes, valid, (320, 240))


def test_shear_along_x_has_opposite_signs_on_the_two_fingers():
    m = field([[160, 120], [200, 100]], [[162, 120], [202, 100]])
    right, _ = wrench(m, "right")
    left, _ = wrench(m, "left")
    assert right[0] == pytest.approx(2.0) and left[0] == pytest.approx(-2.0)
    # xy-norm normal force: |d| = 2 pressed into the right finger (-y) and the left one (+y).
    assert right[1] == pytest.approx(-2.0) and left[1] == pytest.approx(2.0)


def test_image_y_displacement_maps_to_minus_z_on_both_fingers():
    m = field([[160, 120]], [[160, 123]])
    assert marker_forces(m, "right")[0, 2] == pytest.approx(-3.0)
    assert marker_forces(m, "left")[0, 2] == pytest.approx(-3.0)


def test_levers_are_normalised_by_half_the_image_perimeter_and_mirrored_for_the_left_finger():
    m = field([[160 + 28, 120 - 56]], [[160 + 28, 120 - 56]])
    np.testing.assert_allclose(marker_levers(m, "right"), [[0.1, 0.2]])
    np.testing.assert_allclose(marker_levers(m, "left"), [[-0.1, 0.2]])


def test_torque_is_the_lever_cross_force():
    m = field([[188, 64], [100, 200]], [[190, 65], [99, 203]])
    force = marker_forces(m, "right")
    p = marker_levers(m, "right")
    expected = np.cross(np.column_stack([p[:, 0], np.zeros(2), p[:, 1]]), force).mean(axis=0)
    np.testing.assert_allclose(wrench(m, "right")[1], expected)


def test_marker_size_mode_counts_growth_only():
    m = field([[160, 120], [100, 100]], [[160, 120], [100, 100]], size=[10.5, 8.0])
    np.testing.assert_allclose(normal_component(m, "marker_size"), [1.5, 0.0])
    assert wrench(m, "right", "marker_size")[0][1] == pytest.approx(-0.75)


def test_invalid_markers_are_left_out_and_none_valid_gives_zeros():
    m = field([[160, 120], [100, 100]], [[161, 120], [150, 100]], valid=[True, False])
    assert wrench(m, "right")[0][0] == pytest.approx(1.0)
    f, t = wrench(field([[160, 120]], [[165, 120]], valid=[False]), "right")
    assert not f.any() and not t.any()


def test_robust_and_median_averaging_ignore_a_lost_marker():
    origin = np.column_stack([np.linspace(100, 220, 9), np.full(9, 120)])
    position = origin + [1.0, 0.0]
    position[4] += [40.0, 0.0]  # one marker caught on a wrong blob
    m = field(origin, position)
    assert wrench(m, "right", averaging="mean")[0][0] == pytest.approx(1.0 + 40.0 / 9)
    assert wrench(m, "right", averaging="median")[0][0] == pytest.approx(1.0)
    assert wrench(m, "right", averaging="robust")[0][0] == pytest.approx(1.0)


def test_calibration_scales_multiply_the_pixel_wrench():
    m = field([[200, 120]], [[202, 121]])
    f, t = wrench(m, "right")
    fs, ts = wrench(m, "right", force_scale=np.array([0.5, 2.0, 1.0]), torque_scale=3.0)
    np.testing.assert_allclose(fs, f * [0.5, 2.0, 1.0])
    np.testing.assert_allclose(ts, 3.0 * t)


@pytest.mark.parametrize("bad, message", [
    ({"finger": "middle"}, "unknown finger"),
    ({"mode": "area"}, "unknown normal_mode"),
    ({"averaging": "mode"}, "unknown averaging"),
])
def test_bad_options_are_named(bad, message):
    kwargs = {"finger": "right", "mode": "xy_norm", "averaging": "mean"} | bad
    with pytest.raises(ValueError, match=message):
        wrench(field([[160, 120]], [[161, 120]]), kwargs["finger"], kwargs["mode"], kwargs["averaging"])


def test_valid_flags_of_the_wrong_length_are_an_error():
    m = MarkerField(np.zeros((3, 2)), np.zeros((3, 2)), np.ones(3), np.ones(3), np.ones(2, bool))
    with pytest.raises(ValueError, match="3 markers but 2 valid flags"):
        wrench(m, "left")


@pytest.mark.parametrize("averaging", ["mean", "median"])
def test_no_valid_marker_gives_a_zero_wrench(averaging):
    m = MarkerField(np.zeros((3, 2)), np.ones((3, 2)), np.ones(3), np.ones(3), np.zeros(3, bool))
    force, torque = wrench(m, "left", averaging=averaging)
    assert force.tolist() == [0.0, 0.0, 0.0] and torque.tolist() == [0.0, 0.0, 0.0]
