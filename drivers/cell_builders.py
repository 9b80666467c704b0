"""Building a cell from its file: one table maps each kind of cell to the function that builds
it, imported only when a cell of that kind is asked for (a real cell never loads the simulator)."""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path

from drivers.cell import Cell
from drivers.cell_file import CellFileError, read_cell_file, resolve_cell_path
from perception.errors import did_you_mean

# kind -> "module:function" taking (path, data, CellRequest) and returning a Cell.
BUILDERS = {
    "sim": "drivers.sim.cell:build_sim_cell",
    "real": "drivers.hardware.real_cell:build_real_cell",
    "emulated_shadow": "drivers.emulators.shadow:build_shadow_cell",
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


def load_cell(name_or_path: str, tick_hz: float, scene: str = "assembly", scene_args: dict | None = None,
              seed: int = 0, perception: str | None = None) -> Cell:
    """Build the cell described by a cell file (a path, or a packaged cell's name) for a tree
    ticking at `tick_hz` that needs `scene` in simulation."""
    path = resolve_cell_path(name_or_path)
    data = read_cell_file(path)
    request = CellRequest(tick_hz, scene, scene_args or {}, seed, perception)
    module, function = BUILDERS[builder_kind(path, data)].split(":")
    return getattr(importlib.import_module(module), function)(path, data, request)
