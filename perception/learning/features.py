"""Per-tick feature vectors from the two TactileStates, and their spec.

Per finger: the marker field pooled on a GRID of image cells (mean x and y displacement and
mean size change of the markers in each cell, in pixels), then the finger's force (3), torque
(3), object area, centroid (2), orientation and slip. Pooling averages the markers' noise and
makes the vector independent of how many markers a sensor tracks. A model stores the spec it
was trained with; `check_spec` refuses a model whose features differ from the current ones.
"""

from __future__ import annotations

import numpy as np

from perception.state import FINGERS, MarkerField, TactileState

FEATURE_VERSION = 1
GRID = (3, 3)  # columns x rows of image cells
MARKER_CHANNELS = ("dx", "dy", "ds")
REST_TICKS = 15  # a StirLearn trial's first rows: the dipped stick held still (0.5 s at 30 Hz), its reference
SUMMARY = ("fx", "fy", "fz", "tx", "ty", "tz", "area", "cx", "cy", "orientation", "slip")


def columns() -> list[str]:
    """Names of the per-tick feature columns, in order."""
    cols = []
    for finger in FINGERS:
        cols += [f"{finger}.cell{r}{c}.{ch}" for r in range(GRID[1]) for c in range(GRID[0]) for ch in MARKER_CHANNELS]
        cols += [f"{finger}.{name}" for name in SUMMARY]
    return cols


def marker_columns() -> np.ndarray:
    """Indices of the pooled marker-field columns (what ForceLearn regresses on)."""
    return np.array([i for i, name in enumerate(columns()) if ".cell" in name])


def feature_spec() -> dict:
    """What a feature vector means; stored with recordings and models."""
    return {"version": FEATURE_VERSION, "grid": list(GRID), "marker_channels": list(MARKER_CHANNELS),
            "summary": list(SUMMARY), "fingers": list(FINGERS)}


def check_spec(spec: dict, what: str) -> None:
    """Raise ValueError if `spec` (of a model or recording) differs from the current features."""
    current = feature_spec()
    if spec != current:
        diff = sorted(k for k in set(spec) | set(current) if spec.get(k) != current.get(k))
        raise ValueError(f"{what} was made with different features ({', '.join(diff)} differ: "
                         f"{ {k: spec.get(k) for k in diff} } vs current { {k: current.get(k) for k in diff} }); "
                         "record the data again and retrain")


_cells: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}


def _cell_index(markers: MarkerField) -> tuple[np.ndarray, np.ndarray]:
    """Grid cell of each marker origin (cached per layout) and the markers per cell."""
    key = (len(markers), markers.image_size, float(markers.origin[:, 0].sum()) if len(markers) else 0.0)
    if key not in _cells:
        w, h = markers.image_size
        col = np.clip((markers.origin[:, 0] / w * GRID[0]).astype(int), 0, GRID[0] - 1)
        row = np.clip((markers.origin[:, 1] / h * GRID[1]).astype(int), 0, GRID[1] - 1)
        index = row * GRID[0] + col
        _cells[key] = (index, np.maximum(np.bincount(index, minlength=GRID[0] * GRID[1]), 1))
    return _cells[key]


def pooled_markers(markers: MarkerField) -> np.ndarray:
    """(GRID cells x 3) mean dx, dy and size change of the markers in each cell, flattened."""
    n = GRID[0] * GRID[1]
    if not len(markers):
        return np.zeros(n * len(MARKER_CHANNELS))
    index, counts = _cell_index(markers)
    d = markers.displacement
    per_marker = (d[:, 0], d[:, 1], markers.size_change)
    pooled = [np.bincount(index, weights=v, minlength=n) / counts for v in per_marker]
    return np.column_stack(pooled).ravel()


def finger_features(state: TactileState) -> np.ndarray:
    o = state.obj
    summary = [*state.force, *state.torque, o.area, o.centroid[0], o.centroid[1], o.orientation, state.slip]
    return np.concatenate([pooled_markers(state.markers), summary])


def tick_features(left: TactileState, right: TactileState) -> np.ndarray:
    """The feature vector of one tick (see `columns()`)."""
    return np.concatenate([finger_features(left), finger_features(right)])
