"""Domain randomisation of the simulated cell: with `world: {randomise: true}` in the cell file, every
run draws the physical parameters a real cell would not hold to the simulator's defaults from the
ranges below, seeded from the run's seed (the same seed draws the same cell; another seed another).

Each number is drawn from its own stream (seed, group, instance, name), so adding a parameter never
moves the others. A range is either absolute (`low`-`high` in its unit) or a factor on the nominal
value (the scene's default, or what the tree's scene args or the design's scene file give).

What is drawn, and why the range is what it is:

- `sensor`: the FingerVision sensor the simulator runs (both modes); the profile the skills read stays
  the one the cell file names, since a lab's profile is never exactly its sensor.
- `force_sensor`: the UR TCP force reading's offset, drift and noise.
- `world`: the gel's friction against the object, in every scene.
- one group per scene (`assembly`, `assembly.element`, `assembly.plate`, `assembly.support`, `hold`,
  `followme`, `handover`, `handover_press.scale`, `stick`, `press`, `stir`): the object's mass and
  size, the plates' stiffness, loads and supports within design tolerance, the person's pull and
  timing, the followme fingertips' closing-axis cue (camera depth, gel stiffness), the scale.

Off (the default) nothing is drawn and a run is the same bit for bit as before.
"""

from __future__ import annotations

import dataclasses
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivers.sim.models.force_sensor import ForceSensorConfig
from perception.sensor_profile import SensorProfile

RANDOMISE = "randomise"  # the cell file's `world:` switch
STREAM = 0x26D3  # keeps these draws apart from every other stream seeded by the run's seed


@dataclass(frozen=True)
class Range:
    """Where one parameter may lie: `low`-`high` in `unit`, or times the nominal value if `relative`;
    `log`: drawn evenly in log space (for numbers spread over a decade); `why`: the range's source."""

    low: float
    high: float
    unit: str
    why: str
    relative: bool = False
    log: bool = False

    def draw(self, rng: np.random.Generator, nominal: float) -> float:
        """One value: uniform (or log-uniform) within the range, on the nominal if relative."""
        if self.log:
            value = float(np.exp(rng.uniform(np.log(self.low), np.log(self.high))))
        else:
            value = float(rng.uniform(self.low, self.high))
        return value * nominal if self.relative else value

    def bounds(self, nominal: float) -> tuple[float, float]:
        """The range in the parameter's own unit."""
        if not self.relative:
            return self.low, self.high
        ends = (self.low * nominal, self.high * nominal)
        return min(ends), max(ends)

    def describe(self) -> str:
        """`0.6 to 1` or `x0.7 to 1.3` with the unit, for `fvtree scenes`."""
        span = f"x{self.low:g} to {self.high:g}" if self.relative else f"{self.low:g} to {self.high:g} {self.unit}".rstrip()
        return span + (" (log)" if self.log else "")


PRESS_RANGES = {
    "mass": Range(0.7, 1.3, "", "the stick", relative=True),
    "contact_stiffness": Range(0.5, 2.0, "", "scale platform, stick and pads in series", relative=True),
    "scale_noise": Range(0.05, 0.2, "N", "the scale's reading noise"),
}
GROUPS: dict[str, dict[str, Range]] = {
    "sensor": {
        "gain": Range(0.7, 1.3, "", "marker motion per N (normal, shear, torque, size) of one sensor against the "
                      "profile's 0.17 px/N mean: gel thickness and camera distance vary between skins", relative=True),
        "shear_ratio": Range(0.85, 1.15, "", "shear against normal gain: the calibration logs pressed at 0-30 deg "
                             "move the markers about as much per newton", relative=True),
        "rest_jitter_px": Range(0.046, 0.32, "px", "median frame-to-frame marker motion at rest, the calibration "
                                "logs' range across trials (median 0.067)", log=True),
        "skin_lag_s": Range(0.033, 1.0, "s", "fast time constant of the skin; silicone skins 0.1-2 s, the goal of "
                            "issue 26 holds to 1 s"),
        "skin_creep_share": Range(0.0, 0.2, "", "share of a load shown only after creep; silicone creeps a few "
                                  "to ~20 % of its indentation"),
        "skin_creep_s": Range(1.0, 10.0, "s", "creep time constant, silicone elastomers: seconds", log=True),
        "skin_hysteresis": Range(0.0, 1.0, "", "unloading up to twice as slow as loading"),
    },
    "force_sensor": {
        "offset": Range(0.0, 10.0, "N", "UR TCP force offset: 7.5 N on a CB arm, 8.95-13.26 N reading a 10 N "
                        "set point on an e-Series arm"),
        "drift": Range(0.0, 2.0, "N/min", "thermal drift; no published figure"),
        "noise": Range(0.2, 1.0, "N", "e-Series class noise: 0.38 N mean deviation over 1-10 N (the CB series' "
                       "3.6 N is out of this class)"),
    },
    "world": {
        "friction": Range(0.6, 1.0, "", "silicone gel on wood, plastic and glass"),
    },
    "assembly": {
        "force_noise": Range(0.01, 0.03, "", "load noise, share of the plate's true maximum"),
        "ground_stiffness": Range(0.5, 2.0, "", "element foot on the ground (floor and shim)", relative=True),
    },
    "assembly.element": {
        "mass": Range(0.8, 1.2, "", "timber density 350-550 kg/m^3 around the design's", relative=True),
    },
    "assembly.plate": {
        "EI": Range(0.85, 1.15, "", "bending stiffness: plywood and timber stiffness classes +-15 %", relative=True),
        "k": Range(0.7, 1.3, "", "series stiffness of element, grip and gel pads", relative=True),
        "w": Range(0.9, 1.1, "", "uniform load on the plate +-10 %", relative=True),
        "P": Range(0.9, 1.1, "", "point load on the plate +-10 %", relative=True),
        "c": Range(0.95, 1.05, "", "where the point load sits", relative=True),
    },
    "assembly.support": {
        "dx": Range(-0.005, 0.005, "m", "support position along the span, construction tolerance +-5 mm"),
        "dy": Range(-0.005, 0.005, "m", "support position across the span, +-5 mm"),
        "dz": Range(-0.002, 0.002, "m", "support height (the plate's soffit), +-2 mm"),
    },
    "hold": {
        "mass": Range(0.6, 1.4, "", "the empty box", relative=True),
        "extra_load": Range(0.6, 1.2, "", "how much the person pours in", relative=True),
        "load_start": Range(0.5, 2.0, "s", "when the pouring starts after the lift"),
        "load_ramp": Range(2.0, 6.0, "s", "how fast it is poured"),
    },
    "followme": {
        "distance": Range(0.7, 1.3, "", "how far the person leads the block", relative=True),
        "move_time": Range(0.75, 1.5, "", "how fast the person leads it", relative=True),
        "start_delay": Range(0.5, 2.0, "s", "when the person starts after the grasp"),
        "hand_stiffness": Range(150.0, 500.0, "N/m", "a relaxed to a stiff human arm"),
        "max_force": Range(15.0, 35.0, "N", "what a person pulls or pushes with"),
        "vision_noise": Range(0.005, 0.02, "", "centroid noise, share of the image"),
        "camera_depth": Range(0.015, 0.03, "m", "lens behind the skin's surface (the closing-axis cue scales as "
                              "1 / depth): no published figure, the acrylic plate and gel of a fingertip that fits "
                              "a parallel gripper"),
        "pad_stiffness": Range(0.5, 2.0, "", "one pad's gel along its normal (E A / thickness; the closing-axis cue "
                               "scales as 1 / k): no published figure; the gel's modulus is set by its mix (the "
                               "paper softened a too hard Shore A 19 silicone with an additive) and its thickness by "
                               "the mould, a factor 2 either way", relative=True, log=True),
    },
    "handover": {
        "mass": Range(0.7, 1.5, "", "the bottle, empty to full", relative=True),
        "arrive": Range(0.5, 2.0, "s", "when the person brings it"),
        "push": Range(2.0, 6.0, "N", "how hard the person presses it on the pad"),
        "jiggle": Range(0.0015, 0.005, "m", "the person's jiggle"),
        "jiggle_hz": Range(0.8, 2.5, "Hz", "how fast the person jiggles"),
        "reaction": Range(0.2, 0.6, "s", "how long the person feels the grip before letting go"),
        "lift": Range(6.0, 12.0, "N", "how hard the person lifts to take it back"),
        "lift_ramp": Range(0.5, 2.0, "s", "how fast they lift"),
    },
    "handover_press.scale": {  # the press scene's scale under the handed-over stick (its mass is the handover's)
        "contact_stiffness": PRESS_RANGES["contact_stiffness"],
        "scale_noise": PRESS_RANGES["scale_noise"],
    },
    "stick": {
        "mass": Range(0.8, 1.2, "", "the stick", relative=True),
        "com": Range(0.9, 1.1, "", "where its centre of mass sits from the grasp", relative=True),
        "contact_radius": Range(0.75, 1.25, "", "the pads' friction torque radius", relative=True),
        "damping": Range(0.7, 1.3, "", "the gel's resistance to the stick turning in it", relative=True),
    },
    "press": PRESS_RANGES,
    "stir": {
        "surface_z": Range(-0.005, 0.005, "m", "fill level of the bowls (added to the nominal height)"),
        "turn_damping": Range(0.7, 1.3, "", "the stick turning in the gel", relative=True),
    },
}
ADDED = {"stir": {"surface_z"}}  # drawn values added to the nominal, not put in its place
SCENE_GROUPS = {"assembly": ("assembly", "assembly.element", "assembly.plate", "assembly.support"),
                "inhand": ("stick",), "inhand_light": ("stick",), "armrot": ("stick",),
                "handover_press": ("handover", "handover_press.scale")}  # else the scene's name
SHARED_GROUPS = ("sensor", "force_sensor", "world")


def enabled(world: Mapping[str, Any]) -> bool:
    """Whether a cell file's `world:` settings ask for randomised scenes."""
    return bool(world.get(RANDOMISE, False))


def draw(group: str, seed: int, nominal: Mapping[str, float] | None = None, instance: str = "") -> dict[str, float]:
    """One draw of every parameter of `group` for the run `seed` (and `instance`: an element's or a
    plate's id), relative ranges on `nominal`'s values."""
    nominal = nominal or {}
    out = {}
    for name, rng_range in GROUPS[group].items():
        stream = zlib.crc32(f"{group}/{instance}/{name}".encode())
        rng = np.random.default_rng([seed, STREAM, stream])
        base = float(nominal.get(name, 1.0))
        value = rng_range.draw(rng, base)
        out[name] = base + value if name in ADDED.get(group, ()) else value
    return out


def params(cls: type, group: str, given: Mapping[str, Any], world: Mapping[str, Any], seed: int,
           instance: str = "") -> dict[str, Any]:
    """`given` (a scene's constructor arguments) with the parameters of `group` drawn when `world`
    asks for randomised scenes; nominal values from `given`, else the dataclass `cls`'s defaults."""
    out = dict(given)
    if not enabled(world):
        return out
    defaults = {f.name: f.default for f in dataclasses.fields(cls) if f.default is not dataclasses.MISSING}
    nominal = {name: out.get(name, defaults.get(name, 1.0)) for name in GROUPS[group]}
    out.update(draw(group, seed, nominal, instance))
    return out


def world_settings(world: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """The `world:` settings a scene builder gets: the friction drawn when randomised."""
    out = dict(world)
    if enabled(world):
        out.update(draw("world", seed))
    return out


def scene_config(world: Mapping[str, Any]) -> dict[str, Any]:
    """`world` without the switch (what a scene's own config takes)."""
    return {k: v for k, v in world.items() if k != RANDOMISE}


def sensor_profile(profile: SensorProfile, seed: int) -> SensorProfile:
    """The sensor the simulator runs for this seed: the profile's gains scaled, its rest jitter and
    skin drawn."""
    d = draw("sensor", seed)
    gain = d["gain"]
    return dataclasses.replace(
        profile, normal_px_per_n=profile.normal_px_per_n * gain,
        shear_px_per_n=profile.shear_px_per_n * gain * d["shear_ratio"],
        torque_px_per_nm=profile.torque_px_per_nm * gain, size_px_per_n=profile.size_px_per_n * gain,
        rest_jitter_px=d["rest_jitter_px"], skin_lag_s=d["skin_lag_s"], skin_creep_share=d["skin_creep_share"],
        skin_creep_s=d["skin_creep_s"], skin_hysteresis=d["skin_hysteresis"])


def force_sensor(config: ForceSensorConfig, seed: int) -> ForceSensorConfig:
    """The TCP force sensor's errors for this seed."""
    return ForceSensorConfig(**draw("force_sensor", seed))


def groups_of(scene: str) -> tuple[str, ...]:
    """The groups drawn for a scene (besides the shared ones), by its name in `SCENES`."""
    return SCENE_GROUPS.get(scene, (scene,) if scene in GROUPS else ())


def describe(group: str) -> dict[str, str]:
    """{parameter: 'range: why'} of a group, for `fvtree scenes`."""
    return {name: f"{r.describe()}: {r.why}" for name, r in GROUPS[group].items()}
