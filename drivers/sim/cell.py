"""Build the simulated cell from a `kind: sim` cell file and the scene a tree needs."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from drivers.cell import Cell, CellFileError
from drivers.clock import SimClock
from drivers.safety import SafeArm, SafetyLimits
from drivers.sim.arm import KinematicArm
from drivers.sim.assembly_scene import AssemblyScene, Element, Plate, SceneConfig
from drivers.sim.fingervision_model import SensorModel
from drivers.sim.gripper import SimGripper
from drivers.sim import followme_scene, handover_scene, hold_scene, press_scene, stick_scene, stir_scene  # tactile-skill scenes (issue 4)
from drivers.sim.plate import BeamPlate
from perception.state import FINGERS


def _section(path: Path, data: dict, key: str, allowed: set[str], where: str = "") -> dict:
    section = data.get(key) or {}
    if not isinstance(section, dict):
        raise CellFileError(path, where + key, "must be a mapping")
    unknown = set(section) - allowed
    if unknown:
        raise CellFileError(path, f"{where}{key}.{sorted(unknown)[0]}",
                            f"unknown field; known: {', '.join(sorted(allowed))}")
    return section


def build_assembly_scene(arm, gripper, args: dict, world: dict, seed: int) -> AssemblyScene:
    """Elements at their pick poses (with seeded placement error) and the plates to prop."""
    rng = np.random.default_rng(seed + 1)
    elements = {}
    for spec in args.get("elements", []):
        length, width, depth = spec["size"]
        pose = np.array(spec["pick_pose"], dtype=float)
        pose[:2] += rng.uniform(-0.008, 0.008, 2)  # where the element really lies
        true_length = length + rng.uniform(-0.003, 0.003)
        elements[spec["id"]] = Element(spec["id"], true_length, width, depth,
                                       spec.get("mass", 0.4), pose)
    plates = {}
    for spec in args.get("plates", []):
        beam = BeamPlate(span=spec["span"], **spec.get("sim_load", {}))
        plates[spec["id"]] = Plate(spec["id"], np.array(spec["origin"], float),
                                   spec.get("width", 0.3), beam)
    config = SceneConfig(seed=seed, **world)
    return AssemblyScene(arm, gripper, elements, plates, config)


SCENES: dict[str, Callable[..., object]] = {
    "assembly": build_assembly_scene,
    "hold": hold_scene.build,
    "followme": followme_scene.build,
    "handover": handover_scene.build,
    "inhand": stick_scene.builder("inhand"),
    "inhand_light": stick_scene.builder("inhand_light"),
    "armrot": stick_scene.builder("armrot"),
    "press": press_scene.build,
    "stir": stir_scene.build,
}


def register_scene(name: str, builder: Callable[..., object]) -> None:
    """Make a simulated scene available to trees (`cell: {scene: NAME}`)."""
    SCENES[name] = builder


def world_settings(path: Path, data: dict, where: str = "") -> tuple[dict, dict]:
    """The `sensor:` and `world:` settings of a cell file section at `where`, checked."""
    return (_section(path, data, "sensor", set(SensorModel.__dataclass_fields__) - {"finger", "seed"}, where),
            _section(path, data, "world", set(SceneConfig.__dataclass_fields__) - {"seed"}, where))


def simulated_world(path: Path, settings: tuple[dict, dict], arm, gripper, clock, scene: str,
                    scene_args: dict, seed: int) -> tuple[object, dict[str, SensorModel], Callable]:
    """The scene a tree needs around `arm` and `gripper`, with the (sensor, world) `settings`:
    returns the world, its two FingerVision sensor models and the signal-level perception source
    reading them."""
    sensor_cfg, world_cfg = settings
    if scene not in SCENES:
        raise CellFileError(path, "scene", f"no simulated scene {scene!r}; known: {', '.join(sorted(SCENES))}")
    world = SCENES[scene](arm, gripper, scene_args, world_cfg, seed)
    sensors = {f: SensorModel(f, seed=seed * 2 + i, **sensor_cfg) for i, f in enumerate(FINGERS)}

    def sense():
        contacts = world.contacts()
        now = clock.now()
        return {f: sensors[f].state(contacts[f], now) for f in FINGERS}

    return world, sensors, sense


def build_sim_cell(path: Path, data: dict, tick_hz: float, scene: str, scene_args: dict,
                   seed: int = 0, perception: str | None = None) -> Cell:
    allowed = {"kind", "name", "home", "safety", "gripper", "sensor", "world", "perception"}
    unknown = set(data) - allowed
    if unknown:
        raise CellFileError(path, sorted(unknown)[0], f"unknown field; known: {', '.join(sorted(allowed))}")
    try:
        limits = SafetyLimits.from_dict(data.get("safety") or {})
    except (TypeError, ValueError) as exc:
        raise CellFileError(path, "safety", str(exc)) from None
    clock = SimClock(1.0 / tick_hz)
    home = np.array(data.get("home", [0.0, 0.0, 0.5, np.pi, 0.0, 0.0]), dtype=float)
    arm = KinematicArm(clock, home)
    gripper = SimGripper(**_section(path, data, "gripper", {"max_width", "gel_stiffness", "max_speed"}))
    world, sensors, sense = simulated_world(path, world_settings(path, data), arm, gripper, clock,
                                            scene, scene_args, seed)
    mode = perception or data.get("perception", "signals")
    if mode == "pixels":
        from drivers.sim.camera import pixel_level_sense  # rendered frames -> real pipeline

        sense = pixel_level_sense(world, sensors, clock, seed)
    elif mode != "signals":
        raise CellFileError(path, "perception", f"unknown mode {mode!r}; expected signals or pixels")
    safe = SafeArm(arm, limits, clock)
    return Cell(data.get("name", "sim"), safe, gripper, clock, sense, world=world)
