"""The simulated cell's options a benchmark switches on and off: each physics model (the skin's lag,
creep and hysteresis, the TCP force sensor's errors, the arm's acceleration and latency, the markers'
rest jitter, the camera's drawn look), as a change to the sim cell file.

A model is off when the cell file sets it to its ideal: `sensor: {skin_lag_s: 0, skin_creep_share: 0}`
(a transparent skin), `force_sensor: {offset: 0, drift: 0, noise: 0}`, `arm:` all zero (the kinematic
arm), `sensor: {rest_jitter_px: 0}`. On the randomised cell (`world: {randomise: true}`) each seed
draws the skin, the rest jitter and the force sensor's errors anew, over what the file says; so that
an option stays off there too, `pinned` puts its ideal values over the seed's draw, in the bench's own
process only (no cell file can ask for that; a real cell is never randomised). Everything else the
seed draws (gains, scene, plates, supports) stays drawn.

The assembly scene names no gripped object (`drivers/sim/models/objects.py`: the object-dependent
friction, adhesion and marker gain of the hold, follow-me and press scenes), so that model has no
option here: the assembly does not run it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from drivers.cell_file import resolve_cell_path
from drivers.sim.models.force_sensor import ForceSensorConfig
from drivers.sim.scenes import randomise
from perception.sensor_profile import SensorProfile

SKIN_OFF = {"skin_lag_s": 0.0, "skin_creep_share": 0.0}
JITTER_OFF = {"rest_jitter_px": 0.0}
FORCE_SENSOR_OFF = {"offset": 0.0, "drift": 0.0, "noise": 0.0}
ARM_OFF = {"acceleration": 0.0, "angular_acceleration": 0.0, "stop_deceleration": 0.0, "latency": 0.0}


@dataclass(frozen=True)
class SimOption:
    """One setting of the simulated cell: `cell` merges into the sim cell file's sections
    (`{section: {key: value}}`), `sensor` and `force_sensor` are put over each seed's draw on the
    randomised cell (`pinned`), `modes` the perception modes it means anything in."""

    name: str
    about: str
    cell: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    sensor: Mapping[str, float] = field(default_factory=dict)
    force_sensor: Mapping[str, float] = field(default_factory=dict)
    modes: tuple[str, ...] = ("signals", "pixels")


OPTIONS: tuple[SimOption, ...] = (
    SimOption("all models on", "the sim cell file as it is (every model on, default camera look)"),
    SimOption("skin off", "a transparent skin: no lag, creep or hysteresis", {"sensor": SKIN_OFF}, sensor=SKIN_OFF),
    SimOption("force sensor ideal", "the TCP force read without offset, drift or noise",
              {"force_sensor": FORCE_SENSOR_OFF}, force_sensor=FORCE_SENSOR_OFF),
    SimOption("arm ideal", "the kinematic arm: no command latency, no acceleration limit", {"arm": ARM_OFF}),
    SimOption("rest jitter off", "markers without rest jitter (pixel mode: drawn only when they move)",
              {"sensor": JITTER_OFF}, sensor=JITTER_OFF),
    SimOption("look drawn", "pixel mode: the cameras' lighting, background and object colour drawn per seed "
              "(`sensor: {appearance: random}`)", {"sensor": {"appearance": "random"}}, modes=("pixels",)),
    SimOption("all models off", "skin, force sensor, arm and rest jitter all ideal",
              {"sensor": {**SKIN_OFF, **JITTER_OFF}, "force_sensor": FORCE_SENSOR_OFF, "arm": ARM_OFF},
              sensor={**SKIN_OFF, **JITTER_OFF}, force_sensor=FORCE_SENSOR_OFF),
)


def option(name: str) -> SimOption:
    """The option called `name`; KeyError naming the known ones."""
    for o in OPTIONS:
        if o.name == name:
            return o
    raise KeyError(f"no simulation option {name!r}; known: {', '.join(o.name for o in OPTIONS)}")


def option_cell(out_dir: Path, chosen: SimOption, randomised: bool = False) -> Path:
    """A copy of the sim cell file with `chosen`'s sections merged in (and `world: {randomise: true}`
    when `randomised`), written in `out_dir`."""
    data = yaml.safe_load(resolve_cell_path("sim").read_text())
    for section, values in chosen.cell.items():
        data[section] = {**(data.get(section) or {}), **values}
    if randomised:
        data["world"] = {**(data.get("world") or {}), randomise.RANDOMISE: True}
    slug = chosen.name.replace(" ", "_") + ("_randomised" if randomised else "")
    path = out_dir / f"sim_{slug}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@contextmanager
def pinned(chosen: SimOption) -> Iterator[None]:
    """While open, the randomised cell's per-seed sensor and force-sensor draws carry `chosen`'s
    ideal values (see the module docstring); nothing changes for an option without any."""
    if not (chosen.sensor or chosen.force_sensor):
        yield
        return
    draw_sensor, draw_force = randomise.sensor_profile, randomise.force_sensor

    sensor: dict[str, Any] = dict(chosen.sensor)
    force: dict[str, Any] = dict(chosen.force_sensor)

    def sensor_profile(profile: SensorProfile, seed: int) -> SensorProfile:
        return dataclasses.replace(draw_sensor(profile, seed), **sensor)

    def force_sensor(config: ForceSensorConfig, seed: int) -> ForceSensorConfig:
        return dataclasses.replace(draw_force(config, seed), **force)

    randomise.sensor_profile, randomise.force_sensor = sensor_profile, force_sensor
    try:
        yield
    finally:
        randomise.sensor_profile, randomise.force_sensor = draw_sensor, draw_force
