"""`fvtree record TREE --out DATA`: run a tree and keep, for every tick, the feature vector of
the two TactileStates, the labels the simulated scene provides (e.g. the scale reading, the
substance stirred) and the learning example the tree marks as running (/task/stir_trial).
The file format is documented in perception/learning/dataset.py."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from py_trees.blackboard import Blackboard

from assembly.run.options import RunOptions
from assembly.run.session import Run, world_of
from assembly.run.storage import CANNOT_WRITE, StorageError
from behaviours.skill_kit import keys
from drivers.cell import Cell
from perception.learning.dataset import Dataset
from perception.learning.features import columns, feature_spec, tick_features


def record_run(tree_path: str | Path, cell: str = "sim", seed: int = 0, max_time: float = 3600.0,
               perception: str | None = None, scene_args: Mapping[str, Any] | None = None) -> Dataset:
    """Run the tree once (simulated perception from contact `signals` or rendered `pixels`, or the
    cell's own; `scene_args` over the tree's, e.g. the pressed object) and return its per-tick
    dataset; RuntimeError if the run fails."""
    rows: list[np.ndarray] = []
    stamps: list[float] = []
    labels: list[dict] = []
    segments: list[int] = []

    def trial() -> int:
        """The example the tree marked during the last tick (written after that tick's sensing)."""
        current = Blackboard.storage.get(keys.STIR_TRIAL)
        return current["trial"] if current and current.get("active") else -1

    def sense(the_cell: Cell) -> Mapping[str, Any]:
        if rows:
            segments.append(trial())
        states = the_cell.sense()
        rows.append(tick_features(states["left"], states["right"]))
        stamps.append(the_cell.clock.now())
        labels.append(world_of(the_cell).labels())
        return states

    options = RunOptions(cell=cell, seed=seed, perception=perception, max_time=max_time, runs_dir=None,
                         record=False, plots=False, quiet=True, supervised=False, scene_args=dict(scene_args or {}))
    with Run(tree_path, options, sense=sense) as run:
        result = run.loop()
        world, doc = world_of(run.cell), run.doc
    segments.append(trial())
    if result.status != "SUCCESS":
        raise RuntimeError(f"the recording run of {tree_path} (seed {seed}) ended {result.status} at "
                           f"{result.where}: {result.message}")
    names = sorted(set().union(*labels)) if labels else []
    header = {"source": {"tree": str(tree_path), "cell": cell, "scene": doc.scene, "seeds": [seed],
                         "perception": perception or "cell default", **({"scene_args": dict(scene_args)}
                                                                         if scene_args else {})},
              "feature_spec": feature_spec(), "columns": columns(),
              "label_info": world.label_info()}
    return Dataset(header, np.array(stamps), np.zeros(len(rows), np.int32), np.array(segments, np.int32),
                   np.array(rows), {n: np.array([row.get(n) for row in labels]) for n in names})


def record(tree_path: str | Path, out: str | Path, cell: str = "sim", seed: int = 0, runs: int = 1,
           perception: str | None = None, scene_args: Mapping[str, Any] | None = None) -> Path:
    """Record `runs` runs (seeds seed, seed+1, ...) of a tree into one file at `out` (a located
    error, exit 2, when it cannot be written)."""
    parts = [record_run(tree_path, cell, seed + i, perception=perception, scene_args=scene_args) for i in range(runs)]
    header = {**parts[0].header, "source": {**parts[0].header["source"], "seeds": list(range(seed, seed + runs))}}
    try:
        return Dataset.concatenate(parts, header).save(out)
    except OSError as exc:  # a full disk or the file-size limit: a located error, and no torn file left
        Path(out).unlink(missing_ok=True)
        if exc.errno not in CANNOT_WRITE:
            raise
        raise StorageError.of(exc, out, "cannot write the dataset") from None
