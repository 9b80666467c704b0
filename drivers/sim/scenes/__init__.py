"""The simulated scenes a tree can ask for (`cell: {scene: NAME}`), each built around an arm and
a gripper, and the signal-level perception source that reads a scene through the FingerVision
contact model."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from drivers.cell_file import CellFileError, check_values, number, section
from drivers.protocols import Clock, PerceptionSource, SceneArm, SceneGripper, World
from drivers.sim.models.fingervision_model import SensorModel
from drivers.sim.models.skin import Skin
from drivers.sim.scenes import assembly, followme, handover, handover_press, hold, press, randomise, stick, stir
from fvfiles.errors import did_you_mean
from perception.sensor_profile import DEFAULT_PROFILE, NUMBERS, SensorProfile, SensorProfileError, load_profile
from perception.state import FINGERS

# name -> builder(arm, gripper, scene_args, world settings, seed) -> World
SCENES: dict[str, Callable[[SceneArm, SceneGripper, dict, dict, int], World]] = {
    "assembly": assembly.build,
    "hold": hold.build,
    "followme": followme.build,
    "handover": handover.build,
    "handover_press": handover_press.build,
    "inhand": stick.builder("inhand"),
    "inhand_light": stick.builder("inhand_light"),
    "armrot": stick.builder("armrot"),
    "press": press.build,
    "stir": stir.build,
}

# scene name -> the package providing it (plug-in packages add theirs through `assembly.language.plugins`)
SCENE_PACKAGES: dict[str, str] = dict.fromkeys(SCENES, "fvtree")

# `profile`: a profile's name or path; any of the profile's numbers overrides the profile's value
SENSOR_FIELDS = set(SensorModel.__dataclass_fields__) - {"finger", "seed"} | set(NUMBERS) | {"appearance"}
WORLD_FIELDS = set(assembly.SceneConfig.__dataclass_fields__) - {"seed"} | {randomise.RANDOMISE}
# What each setting may be: checked when the cell file is read (a string for a number would fail mid-run).
_PROFILE_VALUES = {name: ({"type": "array", "items": number(1, 4096), "minItems": 2, "maxItems": 2}
                          if name == "image_size" else number(0.0, 1e6)) for name in NUMBERS}
SENSOR_VALUES = {**_PROFILE_VALUES, "noise_px": {"anyOf": [number(0.0, 100.0), {"type": "null"}]},
                 "normal_mode": {"enum": ["xy_norm", "marker_size"]}, "pipeline_errors": {"type": "boolean"},
                 "profile": {"type": "string", "minLength": 1},
                 "appearance": {}}  # a mapping of look fields or `random`: checked by drivers/sim/cell.py
WORLD_VALUES = {"ground_stiffness": number(0.0, 1e8, above=True), "contact_stiffness": number(0.0, 1e8, above=True),
                "friction": number(0.0, 10.0), "view_half": number(0.0, 0.1, above=True),
                "finger_reach": number(0.0, 0.2, above=True), "force_noise": number(0.0, 1.0),
                randomise.RANDOMISE: {"type": "boolean"}}


def world_settings(path: Path, data: dict, where: str = "") -> tuple[dict, dict]:
    """The `sensor:` and `world:` settings of a cell file section at `where`, checked (fields and values)."""
    sensor = section(path, data, "sensor", known=SENSOR_FIELDS, where=where)
    world = section(path, data, "world", known=WORLD_FIELDS, where=where)
    check_values(path, sensor, SENSOR_VALUES, f"{where}sensor.")
    check_values(path, world, WORLD_VALUES, f"{where}world.")
    return sensor, world


def sensor_profile(path: Path, name: object) -> SensorProfile:
    """The sensor profile a cell file's `sensor.profile` names (a packaged profile or a path relative
    to the cell file), or CellFileError naming the field."""
    if not isinstance(name, str):
        raise CellFileError(path, "sensor.profile", f"must be a profile's name or path, got {name!r}")
    relative = Path(path).parent / name
    try:
        return load_profile(str(relative) if relative.suffix in (".yaml", ".yml") and relative.exists() else name)
    except SensorProfileError as exc:
        raise CellFileError(path, "sensor.profile", str(exc)) from None


def cell_profile(path: Path, sensor_cfg: dict) -> tuple[SensorProfile, dict]:
    """The sensor profile a cell file's `sensor:` settings name, with their overrides of its numbers,
    and the settings left for the sensor model; CellFileError naming the field."""
    sensor_cfg = dict(sensor_cfg)
    profile = sensor_profile(path, sensor_cfg.pop("profile", DEFAULT_PROFILE))
    sensor_cfg.pop("appearance", None)  # pixel mode's camera look (drivers/sim/cell.py)
    changed = {key: (tuple(int(v) for v in sensor_cfg.pop(key)) if key == "image_size" else float(sensor_cfg.pop(key)))
               for key in NUMBERS if key in sensor_cfg}
    if changed:
        try:
            profile = dataclasses.replace(profile, **changed)
        except (SensorProfileError, TypeError) as exc:
            raise CellFileError(path, f"sensor.{next(iter(changed))}", str(exc)) from None
    return profile, sensor_cfg


def build_world(path: Path, settings: tuple[dict, dict], arm: SceneArm, gripper: SceneGripper, clock: Clock,
                scene: str, scene_args: dict, seed: int) -> tuple[World, dict[str, SensorModel], PerceptionSource]:
    """The scene a tree needs around `arm` and `gripper`, with the (sensor, world) `settings`:
    returns the world, its two FingerVision sensor models and the signal-level perception source
    reading them through each fingertip's viscoelastic skin (`drivers.sim.models.skin`). With
    `world: {randomise: true}` the sensor and the scene are drawn for `seed` (`randomise`)."""
    profile, sensor_cfg = cell_profile(path, settings[0])
    world_cfg = randomise.world_settings(settings[1], seed)
    if randomise.enabled(world_cfg):
        profile = randomise.sensor_profile(profile, seed)
    if scene not in SCENES:
        raise CellFileError(path, "scene", f"no simulated scene {scene!r}",
                            did_you_mean(scene, SCENES) or f"known: {', '.join(sorted(SCENES))}")
    world = SCENES[scene](arm, gripper, scene_args, world_cfg, seed)
    sensors = {f: SensorModel(f, profile, seed=seed * 2 + i, **sensor_cfg) for i, f in enumerate(FINGERS)}

    skins = {f: Skin(profile) for f in FINGERS}

    def sense():
        contacts = world.contacts()
        now = clock.now()
        return {f: sensors[f].state(skins[f].feel(contacts[f], now), now) for f in FINGERS}

    return world, sensors, sense
