"""A cell bundles arm, gripper, cameras, clock and (simulated) world, and is built from a cell
file (`drivers/cells/*.yaml`). Moving from the simulated cell to a real one is a file change."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import yaml

from drivers.clock import SimClock
from drivers.protocols import Camera, Gripper
from drivers.safety import SafeArm
from perception.state import TactileState

CELLS_DIR = Path(__file__).parent / "cells"


class CellFileError(ValueError):
    """A cell file is missing, malformed or names an unknown field; `field` is a dotted path."""

    def __init__(self, path: str | Path, field: str, message: str):
        self.path, self.field, self.message = str(path), field, message
        super().__init__(f"{path}: {field}: {message}" if field else f"{path}: {message}")


@dataclass
class Cell:
    """Everything a tree acts on. Skills receive it through `tree.setup(cell=...)`."""

    name: str
    arm: SafeArm
    gripper: Gripper
    clock: Any  # SimClock or WallClock
    sense: Callable[[], dict[str, TactileState]]  # the perception source for /fv/<finger>
    cameras: dict[str, Camera] = field(default_factory=dict)
    world: Any = None  # the simulated scene (on an emulated cell, its shadow); None on real hardware
    estop: bool = False  # set by an e-stop input; the runner halts the tree when it is set
    closers: list[Callable[[], None]] = field(default_factory=list)

    @property
    def period(self) -> float:
        return self.clock.period

    @property
    def simulated(self) -> bool:
        """Time is simulated: the cell advances only when stepped (the runner may pace it)."""
        return isinstance(self.clock, SimClock)

    def step(self) -> None:
        """Advance one tick: the world integrates the commands, the clock moves on, and the
        safety layer checks force, faults, watchdog and data age."""
        if self.world is not None:
            self.world.step(self.clock.period)
        self.clock.advance()
        self.arm.supervise()

    def close(self) -> None:
        self.arm.stop()
        for close in reversed(self.closers):
            close()


def resolve_cell_path(name_or_path: str) -> Path:
    """`sim` -> the packaged drivers/cells/sim.yaml; anything else is a path."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.exists():
        return p
    return CELLS_DIR / f"{name_or_path}.yaml"


def read_cell_file(path: Path) -> dict:
    if not path.exists():
        known = ", ".join(sorted(p.stem for p in CELLS_DIR.glob("*.yaml")))
        raise CellFileError(path, "", f"no such cell file (packaged cells: {known})")
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise CellFileError(path, "", f"malformed YAML: {exc}") from None
    if not isinstance(data, dict) or "kind" not in data:
        raise CellFileError(path, "kind", "a cell file is a mapping with 'kind: sim' or 'kind: real'")
    return data


def load_cell(name_or_path: str, tick_hz: float, scene: str, scene_args: dict,
              seed: int = 0, perception: str | None = None) -> Cell:
    """Build the cell described by a cell file, for a tree that needs `scene` in simulation."""
    path = resolve_cell_path(name_or_path)
    data = read_cell_file(path)
    kind = data["kind"]
    if kind == "sim":
        from drivers.sim.cell import build_sim_cell

        return build_sim_cell(path, data, tick_hz, scene, scene_args, seed, perception)
    if kind == "real":
        from drivers.real_cell import build_real_cell

        return build_real_cell(path, data, tick_hz, scene, scene_args, seed)
    raise CellFileError(path, "kind", f"unknown kind {kind!r}; expected 'sim' or 'real'")
