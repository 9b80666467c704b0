"""`fvtree bench ticks`'s speed-against-accuracy and per-tick cost parts on tiny runs: they write their
tables and chart, see the calls they time and switch the models they say; no timing is asserted."""

from __future__ import annotations

import csv
import dataclasses

import pytest

from assembly.bench import tick_costs
from assembly.bench.sim_options import OPTIONS, option, option_cell, pinned
from assembly.cli import main
from drivers.sim.models.force_sensor import ForceSensorConfig
from drivers.sim.models.skin import Skin
from drivers.sim.scenes import randomise
from perception.sensor_profile import load_profile


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_pinned_puts_an_options_ideal_over_the_seeds_draw_and_then_draws_again():
    profile, sensor = load_profile("fingervision_default"), ForceSensorConfig()
    drawn = randomise.sensor_profile(profile, 3)
    with pinned(option("all models off")):
        off = randomise.sensor_profile(profile, 3)
        assert Skin(off).transparent and off.rest_jitter_px == 0.0
        assert off.normal_px_per_n == drawn.normal_px_per_n  # the seed's gains stay drawn
        assert randomise.force_sensor(sensor, 3) == ForceSensorConfig(0.0, 0.0, 0.0)
    assert randomise.sensor_profile(profile, 3) == drawn
    assert randomise.force_sensor(sensor, 3).noise > 0.0


def test_an_options_cell_file_carries_its_change(tmp_path):
    import yaml

    data = yaml.safe_load(option_cell(tmp_path, option("arm ideal"), randomised=True).read_text())
    assert set(data["arm"].values()) == {0.0} and data["world"]["randomise"] is True
    assert data["force_sensor"]["noise"] > 0.0  # the rest of the sim cell as it is


def test_timed_calls_times_a_method_and_puts_it_back():
    feel = Skin.feel
    with tick_costs.timed_calls(("drivers.sim.models.skin:Skin.feel",)) as sinks:
        assert Skin.feel is not feel
        skin = Skin(dataclasses.replace(load_profile("fingervision_default"), skin_lag_s=0.0, skin_creep_share=0.0))
        skin.feel("contact", 0.0)  # a transparent skin hands the contact on as it is
    assert Skin.feel is feel and len(sinks["drivers.sim.models.skin:Skin.feel"]) == 1
    with pytest.raises(RuntimeError, match="Skin.gone is gone"), \
            tick_costs.timed_calls(("drivers.sim.models.skin:Skin.gone",)):
        pass


def test_every_timed_method_of_the_cost_table_is_there():
    """A renamed method stops the bench with an error; this finds it in the fast tier first."""
    with tick_costs.timed_calls(tuple(t for cost in tick_costs.COSTS for t in cost.calls)) as sinks:
        assert all(calls == [] for calls in sinks.values())  # each wrapped, none called yet


@pytest.mark.slow  # a dozen short runs of the assembly in both modes
def test_the_speed_and_cost_parts_write_their_tables_and_chart(tmp_path):
    assert main(["bench", "ticks", "--quick", "--parts", "options", "costs", "--out", str(tmp_path)]) == 0
    options = read_csv(tmp_path / "ticks_options.csv")
    assert {(r["option"], r["mode"]) for r in options} == {(o.name, m) for o in OPTIONS for m in o.modes}
    assert all(float(r["cpu_us_per_tick"]) > 0 and r["runs"] == "1" for r in options)
    assert (tmp_path / "ticks_options.png").stat().st_size > 5_000
    costs = {r["check or model"]: r for r in read_csv(tmp_path / "ticks_costs.csv")}
    assert {c.name for c in tick_costs.COSTS} <= set(costs)
    def calls(name):
        return float(costs[name]["calls per tick"])
    # One cell step a tick (and a few while the arm comes to rest after the run stops), one skin a fingertip.
    assert calls("arm model (latency, acceleration)") == pytest.approx(1.0, abs=0.05)
    assert calls("skin model (lag, creep, hysteresis)") == pytest.approx(2.0, abs=0.1)
    assert calls("Groot2 publish (monitor hook)") == pytest.approx(1.0, abs=0.05)
    assert float(costs["frozen-region check (per-region staleness)"]["calls per tick"]) > 0.0
    assert costs["TCP force-sensor model"]["whole tick µs, off"] != ""  # its side-by-side run was made
    md = (tmp_path / "ticks.md").read_text()
    assert "## Speed against accuracy" in md and "## Per-tick cost of the checks and models" in md
    assert "Tick parts" not in md  # the tick-parts part was not asked for


def test_the_ticks_options_are_its_own(tmp_path, capsys):
    assert main(["bench", "robustness", "--parts", "costs", "--out", str(tmp_path)]) == 2
    assert "do not apply to `fvtree bench robustness`" in capsys.readouterr().err
