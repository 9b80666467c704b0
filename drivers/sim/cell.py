"""Build the simulated cell from a `kind: sim` cell file and the scene a tree needs: an arm with a
UR controller's latency and acceleration limits (the file's `arm:` section) and a gripper with compliant gels, both behind the real safety layer, the scene around them and its
FingerVision perception (from contact signals carrying the real pipeline's measured errors, or
rendered frames through the real pipeline). The
file's `supervision` section is read by the run's cell supervisor (assembly/run/supervisor.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from drivers.cell import Cell
from drivers.cell_builders import CellRequest
from drivers.cell_file import CellFileError, check_known, check_values, config_from, number, section
from drivers.clock import SimClock
from drivers.safe_gripper import SafeGripper
from drivers.safety import SafeArm, SafetyLimits
from drivers.sim.devices.arm import KinematicArm
from drivers.sim.devices.arm_motion import ArmMotion
from drivers.sim.devices.gripper import SimGripper
from drivers.sim.models.appearance import Look, look_from
from drivers.sim.models.force_sensor import ForceSensedArm, ForceSensorConfig
from drivers.sim.scenes import build_world, cell_profile, randomise, world_settings

FIELDS = {"kind", "name", "home", "safety", "supervision", "gripper", "sensor", "world", "perception", "pixel_workers",
          "force_sensor", "arm"}
PERCEPTION_MODES = ("signals", "pixels")
# The simulated gripper's settings: a Robotiq 2F-85 class hand (widths in m, stiffness in N/m, speed in m/s).
GRIPPER_VALUES = {"max_width": number(0.0, 0.5, above=True), "gel_stiffness": number(0.0, 1e7, above=True),
                  "max_speed": number(0.0, 1.0, above=True)}


def build_sim_cell(path: Path, data: dict, request: CellRequest) -> Cell:
    """The simulated cell of the file at `path` (parsed as `data`) for `request`."""
    check_known(path, data, FIELDS)
    try:
        limits = SafetyLimits.from_dict(data.get("safety") or {})
    except (TypeError, ValueError) as exc:
        raise CellFileError(path, "safety", str(exc)) from None
    mode = request.perception or data.get("perception", "signals")
    if mode not in PERCEPTION_MODES:
        raise CellFileError(path, "perception", f"unknown mode {mode!r}; expected signals or pixels")
    workers = data.get("pixel_workers")  # pixel mode's fingers in parallel processes (None: with 2+ cores)
    if workers is not None and not isinstance(workers, bool):
        raise CellFileError(path, "pixel_workers", f"must be true or false (or left out: true with two cores "
                                                   f"or more), got {workers!r}")
    clock = SimClock(1.0 / request.tick_hz)
    home = np.array(data.get("home", [0.0, 0.0, 0.5, np.pi, 0.0, 0.0]), dtype=float)
    # The arm answers as a UR controller: after a command latency, within acceleration limits.
    arm = KinematicArm(clock, home, motion=config_from(path, "arm", ArmMotion, section(path, data, "arm")))
    gripper_settings = section(path, data, "gripper", known=GRIPPER_VALUES)
    check_values(path, gripper_settings, GRIPPER_VALUES, "gripper.")
    gripper = SimGripper(**gripper_settings)
    settings = world_settings(path, data)
    look = _look(path, settings[0].get("appearance"), request.seed)  # checked in both modes, used in pixel mode
    world, sensors, sense = build_world(path, settings, arm, gripper, clock, request.scene, request.scene_args,
                                        request.seed)
    if mode == "signals":  # the pipeline's measured errors, unless the file's sensor section turns them off
        errors = bool(settings[0].get("pipeline_errors", True))
        for sensor in sensors.values():
            sensor.pipeline_errors = errors
    else:
        from drivers.sim.models.synthetic_camera import (
            pixel_level_sense,  # rendered frames -> real pipeline
        )

        sense = pixel_level_sense(world, sensors, clock, request.seed, workers=workers, look=look)
    closers = [sense.close] if mode == "pixels" else []  # pixel mode's worker processes
    # The TCP force the skills and the safety layer read: the scene's force through a UR-class sensor.
    ft = config_from(path, "force_sensor", ForceSensorConfig, section(path, data, "force_sensor"))
    if randomise.enabled(settings[1]):  # drawn per seed; the skills read the profile the file names
        ft = randomise.force_sensor(ft, request.seed)
    profile = cell_profile(path, settings[0])[0] if randomise.enabled(settings[1]) else sensors["left"].profile
    sensed = ForceSensedArm(arm, clock, ft, request.seed)
    return Cell(data.get("name", "sim"), SafeArm(sensed, limits, clock), SafeGripper(gripper), clock, sense,
                world=world, closers=closers, sensor_profile=profile,
                zero_force_sensor=sensed.zero_ft_sensor)


def _look(path: Path, value: object, seed: int) -> Look:
    """Pixel mode's camera look from the file's `sensor.appearance` (fields, `random`, or absent)."""
    if isinstance(value, dict):
        return config_from(path, "sensor.appearance", Look, value)
    try:
        return look_from(value, seed)
    except ValueError as exc:
        raise CellFileError(path, "sensor.appearance", str(exc)) from None
