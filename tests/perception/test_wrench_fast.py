"""The fast wrench (cached lever factors, one pass over the markers) against the plain per-marker
formula: same force and torque on random marker fields, with invalid markers, every normal mode
and averaging, and a marker set that grows after calibration (a new origin array)."""

import numpy as np
import pytest

from perception.state import MarkerField
from perception.wrench import marker_forces, marker_levers, wrench


def reference(markers, finger, mode, averaging, force_scale=1.0, torque_scale=1.0):
    """Force and lever per marker, torque = cross([p0, 0, p1], f), averaged over the valid markers."""
    valid = np.ones(len(markers), bool) if len(markers.valid) == 0 else markers.valid
    if not valid.any():
        return np.zeros(3), np.zeros(3)
    f = marker_forces(markers, finger, mode)[valid]
    p = marker_levers(markers, finger)[valid]
    lever = np.column_stack([p[:, 0], np.zeros(len(p)), p[:, 1]])
    both = np.hstack([f, np.cross(lever, f)])
    if averaging == "mean":
        mean = both.mean(axis=0)
    elif averaging == "median":
        mean = np.median(both, axis=0)
    else:
        q1, q3 = np.percentile(both, [25, 75], axis=0)
        fence = 1.5 * (q3 - q1)
        inside = (both >= q1 - fence) & (both <= q3 + fence)
        mean = np.where(inside, both, 0.0).sum(axis=0) / np.maximum(inside.sum(axis=0), 1)
    return mean[:3] * force_scale, mean[3:] * torque_scale


def random_field(rng, n, origin=None, invalid=0.0, empty_valid=False):
    origin = rng.uniform([0, 0], [320, 240], (n, 2)) if origin is None else origin
    n = len(origin)
    position = origin + rng.normal(0.0, 3.0, (n, 2))
    valid = rng.random(n) >= invalid
    if not empty_valid:  # an empty mask: every marker is valid
        position[~valid] = np.nan  # what a lost marker may hold: must not leak into the average
    origin_size = rng.uniform(6, 12, n)
    size = origin_size + rng.normal(0.0, 1.0, n)
    return MarkerField(origin, position, origin_size, size, np.empty(0, bool) if empty_valid else valid, (320, 240))


@pytest.mark.parametrize("finger", ["left", "right"])
@pytest.mark.parametrize("mode", ["xy_norm", "marker_size"])
@pytest.mark.parametrize("averaging", ["mean", "median", "robust"])
def test_same_force_and_torque_as_the_per_marker_formula(finger, mode, averaging):
    rng = np.random.default_rng(7)
    for trial in range(40):
        m = random_field(rng, int(rng.integers(1, 120)), invalid=(0.0, 0.3, 0.9)[trial % 3],
                         empty_valid=trial % 7 == 0)
        scales = (rng.uniform(0.5, 2.0, 3), rng.uniform(0.5, 2.0, 3)) if trial % 2 else (1.0, 1.0)
        for _ in range(2):  # a second call uses the cached factors
            got = wrench(m, finger, mode, averaging, *scales)
            want = reference(m, finger, mode, averaging, *scales)
            np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-12)
            np.testing.assert_allclose(got[1], want[1], rtol=0, atol=1e-12)


def test_a_marker_set_grown_after_calibration_uses_the_new_origins():
    rng = np.random.default_rng(3)
    first = random_field(rng, 40, invalid=0.2)
    for finger in ("left", "right"):
        np.testing.assert_allclose(wrench(first, finger), reference(first, finger, "xy_norm", "mean"), atol=1e-12)
    grown_origin = np.concatenate([first.origin, rng.uniform([0, 0], [320, 240], (5, 2))])
    for step in range(3):  # the grown map's field on later frames, and the old map's field again
        grown = random_field(rng, 0, origin=grown_origin, invalid=0.1)
        again = random_field(rng, 0, origin=first.origin, invalid=0.1)
        for m in (grown, again):
            for finger in ("left", "right"):
                got = wrench(m, finger)
                want = reference(m, finger, "xy_norm", "mean")
                assert np.isfinite(got[0]).all() and np.abs(got[1]).sum() > 0
                np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-12)
                np.testing.assert_allclose(got[1], want[1], rtol=0, atol=1e-12)


def test_no_valid_marker_gives_zeros_and_a_bad_valid_mask_is_refused():
    rng = np.random.default_rng(5)
    m = random_field(rng, 10, invalid=1.1)
    force, torque = wrench(m, "right")
    assert not force.any() and not torque.any()
    bad = MarkerField(m.origin, m.position, m.origin_size, m.size, np.ones(3, bool), m.image_size)
    with pytest.raises(ValueError, match="10 markers but 3 valid flags"):
        wrench(bad, "right")
