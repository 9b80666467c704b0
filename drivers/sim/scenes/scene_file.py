"""The scene description next to a design file: what the simulated assembly cell knows of the
plates and the design does not (their loads and stiffness), in `<design stem>.scene.yaml`:

    plates:
      P1: {EI: 50.0, w: 80.0, P: 120.0, c: 0.78, k: 2000.0}

Per plate id of the design, all fields optional (missing ones, and plates or whole files that
are missing, take the BeamPlate defaults): EI bending stiffness (N m^2), w uniform load (N/m),
P point load (N) at c (m from the left support, within the span), k series stiffness of element,
grip and gel pads (N/m).
"""

from __future__ import annotations

from pathlib import Path

from drivers.cell_file import CellFileError, check_known, section
from drivers.sim.models.plate import BeamPlate
from fvfiles.errors import did_you_mean
from fvfiles.yaml_source import load_file

LOAD_FIELDS = tuple(name for name in BeamPlate.__dataclass_fields__ if name != "span")
POSITIVE = ("EI", "k")


def scene_file_of(design_file: Path) -> Path:
    """`trees/design/two_bays.json` -> `trees/design/two_bays.scene.yaml`."""
    return design_file.with_name(f"{design_file.stem}.scene.yaml")


def plate_loads(path: Path, spans: dict[str, float]) -> dict[str, dict[str, float]]:
    """Per plate id, the BeamPlate fields the scene file at `path` gives (none if there is no
    file), checked against the design's plates and their `spans`; a CellFileError names the
    file, line and field of the first problem."""
    if not path.exists():
        return {}
    data = load_file(path) or {}  # read with limits: a hostile file is a located SourceError
    if not isinstance(data, dict):
        raise CellFileError(path, "", "a scene file is a mapping with a 'plates' section")
    check_known(path, data, {"plates"})
    plates = section(path, data, "plates")
    loads = {}
    for pid in plates:
        if pid not in spans:
            raise CellFileError(path, f"plates.{pid}", f"the design has no plate {pid!r}",
                                did_you_mean(str(pid), spans) or f"design plates: {', '.join(sorted(spans))}")
        loads[pid] = _checked(path, pid, section(path, plates, pid, known=LOAD_FIELDS, where="plates."),
                              spans[pid])
    return loads


def _checked(path: Path, pid: str, values: dict, span: float) -> dict[str, float]:
    """One plate's fields: numbers, EI and k positive, c within the span."""
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise CellFileError(path, f"plates.{pid}.{name}", f"must be a number, got {value!r}")
        if name in POSITIVE and value <= 0:
            raise CellFileError(path, f"plates.{pid}.{name}", f"must be positive, got {value!r}")
    if not 0.0 <= values.get("c", 0.0) <= span:
        raise CellFileError(path, f"plates.{pid}.c", f"the point load must lie on the span [0, {span:g}] m, "
                            f"got {values['c']!r}")
    return values
