"""Build a real cell from a `kind: real` cell file: a UR arm over ur_rtde behind the safety layer,
a Robotiq gripper over Modbus, OpenCV cameras, and the FingerVision perception stage on them.

Sections: `arm` (UrConfig fields, `driver: ur_rtde`), `gripper` (RobotiqConfig fields, `driver:
robotiq_modbus`, `activate`), `cameras` (finger -> CameraConfig fields), `perception` (`source:
fingervision | shadow | none`, `preset`, `marker_maps`, `stale_after`, `calibration_timeout`, and
for `shadow` the simulated `sensor` and `world` settings), `safety` (SafetyLimits fields), and for
cells of loopback emulators only `emulation` (`time_scale`, `gripper_backdoor_port`). See
drivers/cells/ur_robotiq.yaml and drivers/cells/emulated_shadow.yaml.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from drivers.camera import CameraConfig, OpenCvCamera
from drivers.cell import Cell, CellFileError
from drivers.clock import WallClock
from drivers.gripper_modbus import RobotiqConfig, RobotiqGripper
from drivers.safety import SafeArm, SafetyLimits
from drivers.ur import UrArm, UrConfig
from perception.state import FINGERS, TactileState

SECTIONS = {"kind", "name", "arm", "gripper", "cameras", "perception", "safety", "emulation"}
PERCEPTION_FIELDS = {"source", "preset", "marker_maps", "stale_after", "calibration_timeout", "sensor", "world"}
PERCEPTION_SOURCES = ("fingervision", "shadow", "none")


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


def section(path: Path, data: dict, key: str, required: bool = True) -> dict:
    """A mapping section of the cell file, or CellFileError naming it."""
    value = data.get(key)
    if value is None:
        if required:
            raise CellFileError(path, key, "missing section")
        return {}
    if not isinstance(value, dict):
        raise CellFileError(path, key, "must be a mapping")
    return value


def config_from(path: Path, where: str, cls: type, values: dict, driver: str | None = None) -> Any:
    """Instantiate a config dataclass from a section, with errors that name the field."""
    values = dict(values)
    if driver is not None:
        got = values.pop("driver", driver)
        if got != driver:
            raise CellFileError(path, f"{where}.driver", f"unsupported driver {got!r}; expected {driver!r}")
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise CellFileError(path, f"{where}.{unknown[0]}", f"unknown field; known: {', '.join(sorted(known))}")
    for name, value in values.items():  # YAML lists -> the tuples the dataclasses declare
        if isinstance(value, list):
            values[name] = tuple(value)
    try:
        return cls(**values)
    except (TypeError, ValueError) as exc:
        raise CellFileError(path, where, str(exc)) from None


def parse(path: Path, data: dict) -> dict[str, Any]:
    """Validate the whole file before touching any hardware."""
    unknown = sorted(set(data) - SECTIONS)
    if unknown:
        raise CellFileError(path, unknown[0], f"unknown field; known: {', '.join(sorted(SECTIONS))}")
    safety = section(path, data, "safety")
    try:
        limits = SafetyLimits.from_dict(safety)
    except (TypeError, ValueError) as exc:
        raise CellFileError(path, "safety", str(exc)) from None
    gripper = dict(section(path, data, "gripper"))
    activate = gripper.pop("activate", True)
    cameras = {name: config_from(path, f"cameras.{name}", CameraConfig, spec if isinstance(spec, dict)
                                 else {"source": spec})
               for name, spec in section(path, data, "cameras", required=False).items()}
    perception = parse_perception(path, data, cameras)
    arm = config_from(path, "arm", UrConfig, section(path, data, "arm"), driver="ur_rtde")
    grip = config_from(path, "gripper", RobotiqConfig, gripper, driver="robotiq_modbus")
    return {
        "name": data.get("name", path.stem), "limits": limits, "arm": arm, "gripper": grip,
        "activate": bool(activate), "cameras": cameras, "perception": perception,
        "emulation": parse_emulation(path, data, perception["source"], (arm.host, grip.host)),
    }


def parse_perception(path: Path, data: dict, cameras: dict) -> dict[str, Any]:
    """The `perception` section, with its `source` filled in and, for a shadow world, the
    checked simulated (sensor, world) `settings`."""
    perception = section(path, data, "perception", required=False)
    unknown = sorted(set(perception) - PERCEPTION_FIELDS)
    if unknown:
        raise CellFileError(path, f"perception.{unknown[0]}",
                            f"unknown field; known: {', '.join(sorted(PERCEPTION_FIELDS))}")
    source = perception.get("source", "fingervision" if cameras else "none")
    if source not in PERCEPTION_SOURCES:
        raise CellFileError(path, "perception.source",
                            f"unknown source {source!r}; expected {', '.join(PERCEPTION_SOURCES)}")
    if source == "fingervision" and set(FINGERS) - set(cameras):
        raise CellFileError(path, "cameras", f"perception.source fingervision needs cameras {', '.join(FINGERS)}")
    perception = {**perception, "source": source}
    if source == "shadow":
        from drivers.sim.cell import world_settings

        perception["settings"] = world_settings(path, perception, "perception.")
    return perception


def parse_emulation(path: Path, data: dict, source: str, hosts: tuple[str, str]) -> Emulation:
    """The `emulation` section. It, and a shadow world, need the loopback emulators: only they
    run faster than real time or take object widths from a shadow world."""
    emulation = section(path, data, "emulation", required=False)
    if emulation or source == "shadow":
        why = "an emulation section" if emulation else "perception.source shadow"
        for where, host in zip(("arm.host", "gripper.host"), hosts):
            if not host.startswith("127."):
                raise CellFileError(path, where, f"{why} needs the loopback emulators, but {host} "
                                    "is not a loopback address (a real robot runs in real time)")
    return config_from(path, "emulation", Emulation, emulation)


def no_perception(clock) -> Callable[[], dict[str, TactileState]]:
    """The perception source of a cell without one: unhealthy states that say why."""
    reason = "this cell has no perception source (perception.source: none); run with scripted perception"
    return lambda: {f: TactileState(f, clock.now(), healthy=False, health_reason=reason) for f in FINGERS}


def build_real_cell(path: Path, data: dict, tick_hz: float, scene: str = "assembly",
                    scene_args: dict | None = None, seed: int = 0) -> Cell:
    """Connect every device of the cell file (arm, gripper, cameras) and return the Cell; with
    `perception.source: shadow`, also build the simulated `scene` that follows them."""
    spec = parse(Path(path), data)
    clock = WallClock(1.0 / tick_hz, spec["emulation"].time_scale)
    closers: list[Callable[[], None]] = []
    try:
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
        p, world = spec["perception"], None
        if p["source"] == "shadow":
            from drivers.emulators.shadow import shadow_world

            world, sense = shadow_world(Path(path), spec, arm, gripper, clock, scene, scene_args or {},
                                        seed, closers)
        elif p["source"] == "fingervision":
            from drivers.camera_sense import fingervision_sense

            sense = fingervision_sense(cameras, clock, p.get("preset", "fast"), p.get("marker_maps"),
                                       p.get("stale_after", 0.5), p.get("calibration_timeout", 5.0))
        else:
            sense = no_perception(clock)
    except BaseException:
        for close in reversed(closers):
            close()
        raise
    return Cell(spec["name"], safe, gripper, clock, sense, cameras=cameras, world=world, closers=closers)

