"""Building a cell from its file: one table maps each kind of cell to the function that builds
it, imported only when a cell of that kind is asked for (a real cell never loads the simulator)."""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass, field
from pathlib import Path

from drivers.cell import Cell
from drivers.cell_file import CellFileError, read_cell_file, resolve_cell_path, section
from drivers.safety import SafetyLimits
from fvfiles.errors import did_you_mean

# kind -> "module:function" taking (path, data, CellRequest) and returning a Cell.
BUILDERS = {
    "sim": "drivers.sim.cell:build_sim_cell",
    "real": "drivers.hardware.real_cell:build_real_cell",
    "emulated_shadow": "drivers.emulators.shadow:build_shadow_cell",
}
# kind -> "module:function" taking (path, data) and checking the whole file without opening a device.
PARSERS = {
    "real": "drivers.hardware.real_cell:parse",
    "emulated_shadow": "drivers.emulators.shadow:parse_shadow",
}


@dataclass(frozen=True)
class CellRequest:
    """What the tree asks of the cell: its tick rate and, for a simulated world, the scene."""

    tick_hz: float
    scene: str = "assembly"
    scene_args: dict = field(default_factory=dict)
    seed: int = 0
    perception: str | None = None  # simulated cells: signals | pixels (None: the cell file's)


def builder_kind(path: Path, data: dict) -> str:
    """The BUILDERS entry for a cell file: its `kind`, except that a real cell whose perception
    is a shadow world is an emulated cell with a simulated shadow."""
    kind = data["kind"]
    if kind == "real":
        perception = data.get("perception")
        if isinstance(perception, dict) and perception.get("source") == "shadow":
            return "emulated_shadow"
    if kind not in BUILDERS or kind == "emulated_shadow":
        kinds = sorted(set(BUILDERS) - {"emulated_shadow"})
        raise CellFileError(path, "kind", f"unknown kind {kind!r}",
                            did_you_mean(kind, kinds) or f"expected one of {', '.join(kinds)}")
    return kind


def check_home(path: Path, data: dict) -> None:
    """A cell file's `home` pose (simulated cells) is 6 finite numbers with its position inside
    the safety box (`safety.workspace_min` .. `workspace_max`)."""
    if "home" not in data:
        return
    home = data["home"]
    if not isinstance(home, list) or len(home) != 6 or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in home):
        raise CellFileError(path, "home", f"must be a pose of 6 finite numbers [x, y, z, rx, ry, rz], got {home!r}")
    safety = section(path, data, "safety")
    try:
        limits = SafetyLimits.from_dict(safety)
    except (TypeError, ValueError) as exc:
        raise CellFileError(path, "safety", str(exc)) from None
    lo, hi = limits.workspace_min, limits.workspace_max
    if not all(lo[i] <= home[i] <= hi[i] for i in range(3)):
        raise CellFileError(path, "home", f"position {home[:3]} is outside the safety box {lo.tolist()} .. {hi.tolist()}")


def _build(path: Path, data: dict, request: CellRequest) -> Cell:
    module, function = BUILDERS[builder_kind(path, data)].split(":")
    return getattr(importlib.import_module(module), function)(path, data, request)


def validate(name_or_path: str) -> dict:
    """Check a cell file whole without touching a device; returns its `name` and builder `kind`.
    A real or emulated cell is parsed by its builder module's parser (`PARSERS`); a simulated
    cell, which has no device to touch, is built and closed."""
    path = resolve_cell_path(name_or_path)
    data = read_cell_file(path)
    kind = builder_kind(path, data)
    check_home(path, data)
    if kind in PARSERS:
        module, function = PARSERS[kind].split(":")
        getattr(importlib.import_module(module), function)(path, data)
    else:
        _build(path, data, CellRequest(tick_hz=30.0)).close()
    return {"name": str(data.get("name", path.stem)), "kind": kind}


def load_cell(name_or_path: str, tick_hz: float, scene: str = "assembly", scene_args: dict | None = None,
              seed: int = 0, perception: str | None = None) -> Cell:
    """Build the cell described by a cell file (a path, or a packaged cell's name) for a tree
    ticking at `tick_hz` that needs `scene` in simulation."""
    path = resolve_cell_path(name_or_path)
    data = read_cell_file(path)
    check_home(path, data)
    return _build(path, data, CellRequest(tick_hz, scene, scene_args or {}, seed, perception))
