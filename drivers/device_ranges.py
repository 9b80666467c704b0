"""What a cell's arm and gripper accept, read from its cell file without building the cell or opening a
device, so that `fvtree validate` can check a tree's params against the cell that will run it.

Each range is the one the driver-level safety enforces: `SafeGripper` refuses a force outside
[0, max force] (a real gripper's `force_range`, else the Robotiq 2F-85's 235 N) and a width outside
[0, max_width]; `SafeArm` caps the TCP speed at `safety.max_speed`, refuses a turn faster than
`safety.max_angular_speed` and stops on a TCP force over `safety.max_force`.
"""

from __future__ import annotations

import importlib
import inspect
from dataclasses import dataclass
from pathlib import Path

from drivers.cell_builders import PARSERS, builder_kind
from drivers.cell_file import CELLS_DIR, CellFileError, line_of_field, read_cell_file, resolve_cell_path, section
from drivers.safe_gripper import MAX_FORCE
from drivers.safety import SafetyLimits


@dataclass(frozen=True)
class DeviceRange:
    """One range of a device: [low, high] in `unit`, and where it comes from (file:line field, or a default)."""

    low: float
    high: float
    unit: str
    source: str

    def contains(self, value: float) -> bool:
        return self.low <= value <= self.high


def _source(path: Path, data: dict, field: str, default: str) -> str:
    """Where a range comes from: the file's line of `field` (a dotted path), or the default."""
    name = path.name if path.parent == CELLS_DIR else str(path)  # a packaged cell by its file name
    value: object = data
    for part in field.split("."):
        value = value.get(part) if isinstance(value, dict) else None
    if value is None:
        return f"{default}; {name} sets no {field}"
    return f"{name}:{line_of_field(path, field)} {field}"


def device_ranges(name_or_path: str) -> dict[str, DeviceRange]:
    """The ranges of the cell a file (or a packaged cell's name) describes, by the names of
    `behaviours.skill_kit.base.DEVICE_RANGES`; a CellFileError names the file, line and field of a
    problem in the sections read."""
    path = resolve_cell_path(name_or_path)
    data = read_cell_file(path)
    kind = builder_kind(path, data)
    if kind in PARSERS:  # a real (or emulated) cell: its parser checks the file and reads the gripper config
        module, function = PARSERS[kind].split(":")
        spec = getattr(importlib.import_module(module), function)(path, data)
        limits, grip = spec["limits"], spec["gripper"]
        max_width, max_force = grip.max_width, grip.force_range[1]
        width_from = _source(path, data, "gripper.max_width", "the driver's default")
        force_from = _source(path, data, "gripper.force_range", "the driver's default")
    else:
        try:
            limits = SafetyLimits.from_dict(section(path, data, "safety"))
        except (TypeError, ValueError) as exc:
            raise CellFileError(path, "safety", str(exc)) from None
        from drivers.sim.devices.gripper import SimGripper

        gripper = section(path, data, "gripper")
        max_width = gripper.get("max_width", inspect.signature(SimGripper).parameters["max_width"].default)
        width_from = _source(path, data, "gripper.max_width", "the simulated gripper's default")
        max_force, force_from = MAX_FORCE, "the simulated gripper's Robotiq 2F-85 (drivers/safe_gripper.py)"
    defaults = "the safety default (drivers/safety.py)"
    return {
        "gripper_force": DeviceRange(0.0, float(max_force), "N", force_from),
        "gripper_width": DeviceRange(0.0, float(max_width), "m", width_from),
        "arm_speed": DeviceRange(0.0, limits.max_speed, "m/s", _source(path, data, "safety.max_speed", defaults)),
        "arm_angular_speed": DeviceRange(0.0, limits.max_angular_speed, "rad/s",
                                         _source(path, data, "safety.max_angular_speed", defaults)),
        "arm_force": DeviceRange(0.0, limits.max_force, "N", _source(path, data, "safety.max_force", defaults)),
    }
