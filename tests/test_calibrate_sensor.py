"""`fvtree calibrate-sensor` (assembly/sensor_calibration.py): pressing the press scene's scale in
steps recovers the simulated sensor's gains and rest noise, and writes a profile a cell file can name."""

from __future__ import annotations

import pytest
import yaml

from assembly.cli import main
from assembly.sensor_calibration import run
from drivers.cell_builders import load_cell
from perception.sensor_profile import load_profile

CELLS = __import__("pathlib").Path(__file__).resolve().parents[1] / "drivers" / "cells"


def cell_file(tmp_path, profile: str, name: str = "cell.yaml", **sensor) -> str:
    data = yaml.safe_load((CELLS / "sim_calibration.yaml").read_text())
    data["sensor"] = {"profile": profile, **sensor}
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize("profile", ["fingervision_default", "simulated_2025"])
def test_calibrating_the_simulated_sensor_recovers_its_profile(tmp_path, profile):
    """Two sensors whose gains differ 5-fold (0.17 / 0.17 px/N and 0.032 / 0.178): each measured back
    within 5 %, its rest jitter within 5 %, on a settled skin."""
    truth = load_profile(profile)
    path, cal = run(tmp_path / "measured.yaml", cell=cell_file(tmp_path, profile))
    assert cal.normal_px_per_n == pytest.approx(truth.normal_px_per_n, rel=0.05)
    assert cal.shear_px_per_n == pytest.approx(truth.shear_px_per_n, rel=0.05)
    assert cal.rest_jitter_px == pytest.approx(truth.rest_jitter_px, rel=0.05)
    measured = load_profile(str(path))  # the packaged profiles' format, every number with its source
    assert measured.normal_px_per_n == round(cal.normal_px_per_n, 4)
    assert "measured by calibrate_sensor on " in measured.sources["shear_px_per_n"]
    assert measured.marker_spacing_px == truth.marker_spacing_px  # the rest kept, with its source
    assert measured.sources["marker_spacing_px"] == truth.sources["marker_spacing_px"]


def test_a_lagging_creeping_skin_still_calibrates_within_six_percent(tmp_path):
    """The default skin (creep 5 % over 3 s) hides part of each step's load; the fits take it in their
    intercepts, so the gains stay within 6 %."""
    truth = load_profile("fingervision_default")
    _, cal = run(tmp_path / "measured.yaml", cell=cell_file(tmp_path, "fingervision_default", skin_lag_s=0.1,
                                                                    skin_creep_share=0.05))
    assert cal.normal_px_per_n == pytest.approx(truth.normal_px_per_n, rel=0.06)
    assert cal.shear_px_per_n == pytest.approx(truth.shear_px_per_n, rel=0.06)


def test_the_command_writes_a_profile_a_cell_file_names(tmp_path, capsys):
    out = tmp_path / "lab_sensor.yaml"
    assert main(["calibrate-sensor", "--out", str(out), "--cell", cell_file(tmp_path, "simulated_2025")]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    cell = load_cell(cell_file(tmp_path, "lab_sensor.yaml", name="lab.yaml"), 30, "press")
    assert cell.sensor_profile.name == "lab_sensor"
    assert cell.sensor_profile.shear_px_per_n == pytest.approx(0.178, rel=0.05)
    cell.close()
    assert main(["calibrate-sensor", "--out", str(out), "--object", "jelly"]) == 2
    assert "known: foam, glass, rubber, steel, wood" in capsys.readouterr().err
