"""Design updates checked against the cell that would build them: every pose an update sends (where
an element is picked, where it is planned to stand) must lie inside the cell's workspace box, the
`safety.workspace_min` .. `workspace_max` of its cell file that `drivers.safety.SafeArm` enforces.
An update that fails is refused when it arrives, with the reason; it never reaches a motion, where
the safety layer would clamp it into the box (or, with `out_of_workspace: refuse`, stop the cell)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drivers.cell_file import CellFileError, read_cell_file, resolve_cell_path, section
from drivers.safety import SafetyLimits

POSES = ("pick_pose", "planned_pose")  # what an update may set; as-built poses are the cell's


@dataclass(frozen=True)
class Workspace:
    """The box the cell's arm may reach (metres, robot base frame) and the cell file it is from."""

    low: np.ndarray
    high: np.ndarray
    source: str = "<cell>"

    @classmethod
    def of_cell(cls, name_or_path: str) -> Workspace:
        """The workspace box of a cell file (a path or a packaged cell's name), as SafeArm reads it."""
        path = resolve_cell_path(name_or_path)
        try:
            limits = SafetyLimits.from_dict(section(path, read_cell_file(path), "safety"))
        except (TypeError, ValueError) as exc:
            raise CellFileError(path, "safety", str(exc)) from None
        return cls(limits.workspace_min, limits.workspace_max, str(path))

    def problem(self, element: dict) -> str | None:
        """Why the element's poses are out of this cell's reach, or None."""
        for key in POSES:
            pose = element.get(key)
            if pose is None:
                continue
            position = np.asarray(pose[:3], float)
            if np.all(position >= self.low) and np.all(position <= self.high):
                continue
            axes = [f"{'xyz'[i]} {position[i]:g} not in [{self.low[i]:g}, {self.high[i]:g}]"
                    for i in range(3) if not self.low[i] <= position[i] <= self.high[i]]
            return (f"{element.get('id')}: {key} {np.round(position, 4).tolist()} is outside the cell's workspace "
                    f"({', '.join(axes)}; safety box of {self.source})")
        return None
