"""Benchmark metrics and table output (the benchmark itself is a command, not a test)."""

import numpy as np

from assembly.bench.perception.metrics import best_threshold, f1, jitter_and_lag, real_swaps, relative_jumps
from assembly.bench.perception.report import write_table


def test_f1_and_threshold_tuning():
    actual = np.array([False, False, True, True])
    assert f1(np.array([False, True, True, True]), actual) == 0.8
    assert best_threshold(np.array([0.01, 0.02, 0.5, 0.6]), actual) == 0.02


def test_jitter_and_lag_of_a_known_filter_output():
    at, step = 30, 2.0
    truth = np.zeros((50, 4))
    truth[at:] = step
    rng = np.random.default_rng(0)
    raw = truth + rng.normal(0, 0.2, truth.shape)
    filtered = truth + rng.normal(0, 0.05, truth.shape)
    filtered[at:at + 3] = 0.0  # three frames late
    jitter, lag = jitter_and_lag(raw, filtered, truth, at, step)
    assert 3.0 < jitter < 5.5
    assert lag == 3


def test_real_footage_swap_and_jump_checks():
    origin = np.array([[0.0, 0.0], [30.0, 0.0], [60.0, 0.0], [90.0, 0.0]])
    valid = np.ones(4, bool)
    shifted = origin + [2.0, 0.0]
    assert real_swaps(shifted, valid, origin) == 0
    swapped = shifted.copy()
    swapped[1] = origin[2] + [2.0, 0.0]  # marker 1 sits where marker 2 belongs
    assert real_swaps(swapped, valid, origin) == 1
    assert relative_jumps(shifted, origin, valid) == 0
    assert relative_jumps(swapped, shifted, valid) == 1


def test_tables_are_written_as_csv_and_markdown(tmp_path):
    paths = write_table(tmp_path, "t", [{"a": 1, "b": 0.123456}], "Title", "note")
    assert [p.name for p in paths] == ["t.csv", "t.md"]
    assert paths[0].read_text().splitlines() == ["a,b", "1,0.123456"]
    assert "| 1 | 0.1235 |" in paths[1].read_text()


def test_stress_conditions_reach_the_failure_points_of_the_issue():
    from assembly.bench.perception import _stress_sequences
    conditions = {}
    for factor, value, seq in _stress_sequences(2):
        conditions.setdefault(factor, []).append(value)
        assert len(seq.frames) == 2 and len(seq.calibration) == 10 and len(seq.origin) > 50
    assert max(conditions["shear_px"]) == 25 and max(conditions["torsion_px"]) >= 20
    assert max(conditions["textured_share"]) == max(conditions["dark_share"]) == 0.4
    assert max(conditions["gain_bright_background"]) >= 2.0
    assert max(conditions["blur_kernel_px"]) == 15 and max(conditions["noise_sigma"]) == 24


def test_objects_behind_the_skin_change_the_skin_not_the_markers():
    import cv2

    from assembly.bench.perception.scenes import StressBench
    from drivers.sim.models.synthetic_camera import Appearance
    look = Appearance(noise=0.0)
    plain = StressBench(4).camera.render(appearance=look)
    for pattern, darker in (("qr", True), ("dark", True), ("bright", False)):
        frame = StressBench(4, pattern, 0.4).camera.render(appearance=look)
        assert frame.truth.visible.all() and np.allclose(frame.truth.position, plain.truth.position)
        change = cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY).astype(float) - cv2.cvtColor(
            plain.image, cv2.COLOR_BGR2GRAY)
        assert (change < -40).mean() > 0.05 if darker else (change > 20).mean() > 0.05
        centres = np.rint(plain.truth.position).astype(int)
        core = frame.image[centres[:, 1], centres[:, 0]].max(axis=1)
        assert core.max() < 60  # every marker is still drawn black on top of the object
