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


def test_a_lagging_creeping_skin_still_calibrates_within_three_percent(tmp_path):
    """A skin with creep (5 % over 3 s) hides part of each step's load for seconds; the gain steps are
    held for the creep the response measured (3 creep times), so the gains stay within 3 %."""
    truth = load_profile("fingervision_default")
    _, cal = run(tmp_path / "measured.yaml", cell=cell_file(tmp_path, "fingervision_default", skin_lag_s=0.1,
                                                                    skin_creep_share=0.05))
    assert cal.normal_px_per_n == pytest.approx(truth.normal_px_per_n, rel=0.03)
    assert cal.shear_px_per_n == pytest.approx(truth.shear_px_per_n, rel=0.03)
    assert cal.skin is not None and cal.skin.creep_share == pytest.approx(0.05, abs=0.02)
    assert cal.hold_ticks > 300  # 3 creep times of 1.3 x 3 s, not the plan's 2 s


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


@pytest.mark.parametrize("lag", [0.1, 0.5, 1.0])
def test_the_press_and_hold_recovers_the_skins_lag(tmp_path, lag):
    """The simulated skin with a known lag (and the default profile's creep and hysteresis): the step
    on the scale and back gives the lag within 15 %, written into the profile with its source."""
    path, cal = run(tmp_path / "measured.yaml", cell=cell_file(tmp_path, "fingervision_default", skin_lag_s=lag,
                                                               skin_creep_share=0.05))
    assert cal.skin is not None and cal.skin.lag_s == pytest.approx(lag, rel=0.15)
    loads = [f for f, _ in cal.response]
    assert min(loads) < 3.0 and max(loads) > 6.0  # the step was made: about 2 N and 8 N on the scale
    measured = load_profile(str(path))
    assert measured.skin_lag_s == round(cal.skin.lag_s, 4)
    assert "measured by calibrate_sensor on " in measured.sources["skin_lag_s"]
    assert "fitted with the skin model" in measured.sources["skin_lag_s"]
    if cal.skin.creep_share is None:  # not told apart: the profile's creep kept, saying so
        assert measured.skin_creep_share == load_profile("fingervision_default").skin_creep_share
        assert "told no creep apart" in measured.sources["skin_creep_share"]
    else:
        assert measured.skin_creep_share == round(cal.skin.creep_share, 4)
        assert cal.skin.creep_share == pytest.approx(0.05, abs=0.03)
    assert cal.normal_px_per_n == pytest.approx(0.17, rel=0.03)  # each gain step held until the skin showed it
    assert cal.shear_px_per_n == pytest.approx(0.17, rel=0.03)


@pytest.mark.parametrize("seed", [1, 13, 16])
def test_the_randomised_cell_calibrates_to_its_drawn_skin(tmp_path, seed):
    """On the randomised cell (the sensor, skin, scale stiffness and noise and grip friction drawn per
    seed: lags 0.75, 0.34 and 0.20 s; seed 13's scale is twice as stiff) the calibration measures the
    drawn sensor, not the profile the cell file names."""
    from drivers.sim.scenes import randomise
    from perception.sensor_profile import default_profile

    truth = randomise.sensor_profile(default_profile(), seed)
    data = yaml.safe_load((CELLS / "sim.yaml").read_text())
    data["world"] = {**data.get("world", {}), "randomise": True}
    cell = tmp_path / "randomised.yaml"
    cell.write_text(yaml.safe_dump(data))
    _, cal = run(tmp_path / "measured.yaml", cell=str(cell), seed=seed)
    assert cal.skin is not None and cal.skin.lag_s == pytest.approx(truth.skin_lag_s, rel=0.15)
    assert cal.normal_px_per_n == pytest.approx(truth.normal_px_per_n, rel=0.05)
    assert cal.shear_px_per_n == pytest.approx(truth.shear_px_per_n, rel=0.1)
    assert abs(cal.skin.lag_s - default_profile().skin_lag_s) > 0.1  # the drawn skin, not the named profile's
