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
