"""Build a real cell from a `kind: real` cell file: a UR arm over ur_rtde behind the safety layer,
a Robotiq gripper over Modbus, OpenCV cameras, and the FingerVision perception stage on them.

Sections: `arm` (UrConfig fields, `driver: ur_rtde`), `gripper` (RobotiqConfig fields, `driver:
robotiq_modbus`, `activate`), `cameras` (finger -> CameraConfig fields), `perception` (`source:
fingervision | none`, `preset`, `marker_maps`, `stale_after`, `calibration_timeout`), `safety`
(SafetyLimits fields). See drivers/cells/ur_robotiq.yaml.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Callable

from drivers.camera import CameraConfig, OpenCvCamera
from drivers.cell import Cell, CellFileError
from drivers.clock import WallClock
from drivers.gripper_modbus import RobotiqConfig, RobotiqGripper
from drivers.safety import SafeArm, SafetyLimits
from drivers.ur import UrArm, UrConfig
from perception.state import FINGERS, TactileState

SECTIONS = {"kind", "name", "arm", "gripper", "cameras", "perception", "safety"}
PERCEPTION_FIELDS = {"source", "preset", "marker_maps", "stale_after", "calibration_timeout"}


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
    perception = section(path, data, "perception", required=False)
    unknown = sorted(set(perception) - PERCEPTION_FIELDS)
    if unknown:
        raise CellFileError(path, f"perception.{unknown[0]}",
                            f"unknown field; known: {', '.join(sorted(PERCEPTION_FIELDS))}")
    source = perception.get("source", "fingervision" if cameras else "none")
    if source not in ("fingervision", "none"):
        raise CellFileError(path, "perception.source", f"unknown source {source!r}; expected fingervision or none")
    if source == "fingervision" and set(FINGERS) - set(cameras):
        raise CellFileError(path, "cameras", f"perception.source fingervision needs cameras {', '.join(FINGERS)}")
    return {
        "name": data.get("name", path.stem), "limits": limits,
        "arm": config_from(path, "arm", UrConfig, section(path, data, "arm"), driver="ur_rtde"),
        "gripper": config_from(path, "gripper", RobotiqConfig, gripper, driver="robotiq_modbus"),
        "activate": bool(activate), "cameras": cameras, "perception": {**perception, "source": source},
    }


def no_perception(clock) -> Callable[[], dict[str, TactileState]]:
    """The perception source of a cell without one: unhealthy states that say why."""
    reason = "this cell has no perception source (perception.source: none); run with scripted perception"
    return lambda: {f: TactileState(f, clock.now(), healthy=False, health_reason=reason) for f in FINGERS}


def build_real_cell(path: Path, data: dict, tick_hz: float) -> Cell:
    """Connect every device of the cell file (arm, gripper, cameras) and return the Cell."""
    spec = parse(Path(path), data)
    clock = WallClock(1.0 / tick_hz)
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
        p = spec["perception"]
        if p["source"] == "fingervision":
            from drivers.camera_sense import fingervision_sense

            sense = fingervision_sense(cameras, clock, p.get("preset", "fast"), p.get("marker_maps"),
                                       p.get("stale_after", 0.5), p.get("calibration_timeout", 5.0))
        else:
            sense = no_perception(clock)
    except BaseException:
        for close in reversed(closers):
            close()
        raise
    return Cell(spec["name"], safe, gripper, clock, sense, cameras=cameras, closers=closers)

