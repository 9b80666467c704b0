"""`fvtree bench recording --quick` runs and writes its table and chart (timings are not asserted:
benchmarks show speed, tests show behaviour)."""

from __future__ import annotations

import pytest

from assembly.cli import main

pytestmark = pytest.mark.slow  # a whole benchmark (quick mode)


def test_bench_recording_quick(tmp_path, capsys):
    assert main(["bench", "recording", "--quick", "--out", str(tmp_path)]) == 0
    table = (tmp_path / "recording.md").read_text()
    assert "| without recording |" in table and "| with recording |" in table
    assert "MB per minute of cell time" in table
    rows = (tmp_path / "recording.csv").read_text().splitlines()
    assert len(rows) == 1 + 6  # header, three runs each way
    assert (tmp_path / "recording.png").stat().st_size > 0
