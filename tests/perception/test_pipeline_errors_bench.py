"""The error bench (`assembly/bench/perception/error_model_fit.py`): a pixel-mode run recorded beside its
truth, and the error model fitted to it agrees with the one signals mode ships."""

from __future__ import annotations

from pathlib import Path

import pytest

from assembly.bench.perception.error_model_fit import measure, run
from assembly.bench.perception.pixel_runs import record
from drivers.sim.models.pipeline_error_model import PipelineErrors

TREES = Path(__file__).resolve().parents[2] / "trees"


@pytest.fixture(scope="module")
def hold_recording():
    return record(TREES / "hold.yaml", max_time=30.0)


def test_a_recording_holds_truth_and_pipeline_for_every_tick(hold_recording):
    ticks = hold_recording.ticks["left"]
    assert hold_recording.status == "SUCCESS" and len(ticks) == len(hold_recording.ticks["right"]) > 300
    tick = ticks[-1]
    assert tick.position.shape == tick.state.markers.position.shape  # matched to the pipeline's markers
    assert abs(tick.position - tick.state.markers.position).mean() < 0.5


def test_the_fitted_model_is_the_one_signals_mode_ships(hold_recording):
    rows, model = measure([hold_recording])
    shipped = PipelineErrors()
    assert model.noise_px == pytest.approx(shipped.noise_px, rel=0.5)
    assert model.area_scale == pytest.approx(shipped.area_scale, abs=0.08)
    assert model.centroid_px == pytest.approx(shipped.centroid_px, rel=0.5)
    assert 0.2 <= model.lag_alpha <= 1.0 and model.slip_floor < 0.01
    assert {r["run"] for r in rows[:-1]} == {"hold.yaml", "all (fitted model)"}
    fitted = rows[-2]  # the pipeline's errors persist from tick to tick; the bench reports how much
    assert fitted["noise_corr"] > 0.9 and 0.5 < fitted["lossy_hold"] <= 1.0 and 0.0 < fitted["object_corr"] < 1.0


def test_the_bench_writes_its_tables_and_model(tmp_path, monkeypatch):
    import assembly.bench.perception.error_model_fit as bench

    monkeypatch.setattr(bench, "QUICK_RUNS", ("hold.yaml",))
    written = run(tmp_path, quick=True)
    assert {p.name for p in written} == {"errors.csv", "errors.md", "slip_errors.csv", "slip_errors.md",
                                         "pipeline_errors.json"}
    assert "all (fitted model)" in (tmp_path / "errors.md").read_text()
