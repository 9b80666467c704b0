"""Build a real cell from a `kind: real` cell file: a UR arm over ur_rtde and a Robotiq gripper over
Modbus, both behind the safety layer, OpenCV cameras, and the FingerVision perception stage on them.

Sections: `arm` (UrConfig fields, `driver: ur_rtde`), `gripper` (RobotiqConfig fields, `driver:
robotiq_modbus`, `activate`), `cameras` (finger -> CameraConfig fields), `perception` (`source:
fingervision | none`, `preset`, `marker_maps`, `stale_after`, `calibration_timeout`), `safety`
(SafetyLimits fields), `supervision` (read by the run's cell supervisor, assembly/run/supervisor.py),
and for cells of loopback emulators only `emulation` (`time_scale`, back-door ports, `pad_stiffness`). The whole file is checked before any device is touched. See
drivers/cells/ur_robotiq.yaml and drivers/cells/emulated.yaml; a cell whose perception is a shadow
world (drivers/cells/emulated_shadow.yaml) is built by drivers/emulators/shadow.py on top of this.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drivers.cell import Cell
from drivers.cell_builders import CellRequest
from drivers.cell_file import CellFileError, check_known, config_from, section
from drivers.clock import WallClock
from drivers.hardware.camera import CameraConfig, OpenCvCamera
from drivers.hardware.gripper_modbus import RobotiqConfig, RobotiqGripper
from drivers.hardware.ur import UrArm, UrConfig
from drivers.loopback import is_loopback
from drivers.safe_gripper import SafeGripper
from drivers.safety import SafeArm, SafetyLimits
from perception.calibration import CalibrationError, MarkerMap
from perception.config import ConfigError, FingerVisionConfig, load_config, preset_names
from perception.state import FINGERS, TactileState

SECTIONS = {"kind", "name", "arm", "gripper", "cameras", "perception", "safety", "supervision", "emulation"}
PERCEPTION_FIELDS = {"source", "preset", "marker_maps", "stale_after", "calibration_timeout"}
PERCEPTION_SOURCES = ("fingervision", "none")
PERCEPTION_DEFAULTS = {"preset": "fast", "stale_after": 0.5, "calibration_timeout": 5.0}  # times in s


@dataclass(frozen=True)
class Emulation:
    """The cell file's `emulation:` section, for cells whose devices are the loopback emulators."""

    time_scale: float = 1.0  # emulated seconds per wall second: the emulators and the cell clock
    arm_backdoor_port: int = 30999  # where the shadow world hands the UR emulator its loads
    gripper_backdoor_port: int = 30998  # where the shadow world tells the gripper emulator about objects
    pad_stiffness: float = 5000.0  # N/m, the FingerVision gel pads on the emulated fingers (as sim.yaml)

    def __post_init__(self):
        if not 0 < self.time_scale <= 100:
            raise ValueError(f"time_scale must be in (0, 100], got {self.time_scale}")
        if self.pad_stiffness <= 0:
            raise ValueError(f"pad_stiffness must be positive, got {self.pad_stiffness}")


def parse(path: Path, data: dict, shadow: bool = False) -> dict[str, Any]:
    """Validate the whole file before touching any hardware; `shadow` also admits the shadow
    world's perception fields (checked by its builder)."""
    check_known(path, data, SECTIONS)
    try:
        limits = SafetyLimits.from_dict(section(path, data, "safety", required=True))
    except (TypeError, ValueError) as exc:
        raise CellFileError(path, "safety", str(exc)) from None
    gripper = dict(section(path, data, "gripper", required=True))
    activate = gripper.pop("activate", True)
    cameras = {name: config_from(path, f"cameras.{name}", CameraConfig, spec if isinstance(spec, dict)
                                 else {"source": spec})
               for name, spec in section(path, data, "cameras").items()}
    perception = parse_perception(path, data, cameras, shadow)
    arm = config_from(path, "arm", UrConfig, section(path, data, "arm", required=True), driver="ur_rtde")
    grip = config_from(path, "gripper", RobotiqConfig, gripper, driver="robotiq_modbus")
    return {
        "name": data.get("name", path.stem), "limits": limits, "arm": arm, "gripper": grip,
        "activate": bool(activate), "cameras": cameras, "perception": perception,
        "emulation": parse_emulation(path, data, shadow, (arm.host, grip.host)),
    }


def parse_perception(path: Path, data: dict, cameras: dict[str, CameraConfig], shadow: bool = False
                     ) -> dict[str, Any]:
    """The `perception` section, with its `source` filled in and the FingerVision pipeline's
    `config` and marker `maps` loaded, so a wrong preset name or map file fails here, before any
    device is touched."""
    known = PERCEPTION_FIELDS | ({"sensor", "world"} if shadow else set())
    perception = {**PERCEPTION_DEFAULTS, **section(path, data, "perception", known=known)}
    source = perception.get("source", "fingervision" if cameras else "none")
    sources = PERCEPTION_SOURCES + (("shadow",) if shadow else ())
    if source not in sources:
        raise CellFileError(path, "perception.source",
                            f"unknown source {source!r}; expected {', '.join(sources)}")
    if source == "fingervision" and set(FINGERS) - set(cameras):
        raise CellFileError(path, "cameras", f"perception.source fingervision needs cameras {', '.join(FINGERS)}")
    for name in ("stale_after", "calibration_timeout"):
        value = perception[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value <= 0:
            raise CellFileError(path, f"perception.{name}", f"must be a positive number of seconds, got {value!r}")
    return {**perception, "source": source, "config": pipeline_config(path, perception["preset"]),
            "maps": marker_maps(path, perception.get("marker_maps"), cameras)}


def pipeline_config(path: Path, preset: Any) -> FingerVisionConfig:
    """The FingerVision configuration `perception.preset` names (a shipped preset or a YAML file)."""
    if not isinstance(preset, str):
        raise CellFileError(path, "perception.preset", f"must be a preset name or a YAML file, got {preset!r}",
                            f"presets: {', '.join(preset_names())}")
    try:
        return load_config(preset)
    except ConfigError as exc:
        raise CellFileError(path, "perception.preset", str(exc)) from None  # the preset file's own line too


def marker_maps(path: Path, files: Any, cameras: dict[str, CameraConfig]) -> dict[str, MarkerMap]:
    """Per finger, the saved marker map `perception.marker_maps` names (fingers without one are
    calibrated at start): each file must load, hold markers and match its camera's image size."""
    if files is None:
        return {}
    if not isinstance(files, dict):
        raise CellFileError(path, "perception.marker_maps", "must map fingers to marker map files",
                            "e.g. {left: calib/left.yaml, right: calib/right.yaml}")
    check_known(path, files, FINGERS, "perception.marker_maps.")
    maps = {}
    for finger, file in files.items():
        where = f"perception.marker_maps.{finger}"
        if not Path(str(file)).is_file():
            raise CellFileError(path, where, f"no marker map file {file}", "paths are relative to the working directory")
        try:
            found = MarkerMap.load(Path(str(file)))
        except CalibrationError as exc:
            raise CellFileError(path, where, exc.message) from None
        if len(found) == 0:
            raise CellFileError(path, where, f"{file}: the marker map has no markers",
                                "recalibrate on frames that show the markers")
        camera = cameras.get(finger)
        captured = (camera.width, camera.height) if camera is not None else (None, None)
        if None not in captured and captured != tuple(found.image_size):
            raise CellFileError(path, where, f"{file}: the map is for {found.image_size[0]}x{found.image_size[1]} "
                                f"images, camera {finger} captures {captured[0]}x{captured[1]}")
        maps[finger] = found
    return maps


def parse_emulation(path: Path, data: dict, shadow: bool, hosts: tuple[str, str]) -> Emulation:
    """The `emulation` section. It, and a shadow world, need the loopback emulators: only they
    run faster than real time or take object widths from a shadow world."""
    emulation = section(path, data, "emulation")
    if emulation or shadow:
        why = "an emulation section" if emulation else "perception.source shadow"
        for where, host in zip(("arm.host", "gripper.host"), hosts):
            if not is_loopback(host):
                raise CellFileError(path, where, f"{why} needs the loopback emulators, but {host} "
                                    "is not a loopback address (a real robot runs in real time)")
    return config_from(path, "emulation", Emulation, emulation)


def no_perception(clock) -> Callable[[], dict[str, TactileState]]:
    """The perception source of a cell without one: unhealthy states that say why."""
    reason = "this cell has no perception source (perception.source: none); run with scripted perception"
    return lambda: {f: TactileState(f, clock.now(), healthy=False, health_reason=reason) for f in FINGERS}


@dataclass(frozen=True)
class Devices:
    """The connected devices of a cell: each driver, and the arm and gripper behind the safety layer."""

    arm: UrArm
    gripper: RobotiqGripper
    safe_arm: SafeArm
    safe_gripper: SafeGripper
    cameras: dict[str, OpenCvCamera]


def connect(spec: dict[str, Any], clock: WallClock, closers: list[Callable[[], None]]) -> Devices:
    """Connect arm and gripper (each behind the safety layer) and cameras of a parsed cell file;
    each device's close joins `closers` as soon as it is open."""
    arm = UrArm(spec["arm"], clock)
    closers.append(arm.close)
    safe = SafeArm(arm, spec["limits"], clock)
    safe.start_watchdog()  # runs from the first tick on
    closers.append(safe.stop_watchdog)
    gripper = RobotiqGripper(spec["gripper"])
    closers.append(gripper.close)
    if spec["activate"]:
        gripper.activate()
    cameras = {name: OpenCvCamera(name, cfg, clock) for name, cfg in spec["cameras"].items()}
    closers.extend(c.close for c in cameras.values())
    return Devices(arm, gripper, safe, SafeGripper(gripper, max_force=spec["gripper"].force_range[1]), cameras)


def closing_on_error(closers: list[Callable[[], None]], build: Callable[[], Cell]) -> Cell:
    """`build()`, closing whatever it opened (in reverse) if it raises."""
    try:
        return build()
    except BaseException:
        for close in reversed(closers):
            close()
        raise


def build_real_cell(path: Path, data: dict, request: CellRequest) -> Cell:
    """Connect every device of the cell file (arm, gripper, cameras) and return the Cell."""
    spec = parse(Path(path), data)
    clock = WallClock(1.0 / request.tick_hz, spec["emulation"].time_scale)
    closers: list[Callable[[], None]] = []

    def build() -> Cell:
        devices = connect(spec, clock, closers)
        p = spec["perception"]
        if p["source"] == "fingervision":
            from drivers.hardware.camera_sense import fingervision_sense

            sense = fingervision_sense(devices.cameras, clock, p["config"], p["maps"], p["stale_after"],
                                       p["calibration_timeout"])
        else:
            sense = no_perception(clock)
        return Cell(spec["name"], devices.safe_arm, devices.safe_gripper, clock, sense, cameras=devices.cameras,
                    closers=closers)

    return closing_on_error(closers, build)
