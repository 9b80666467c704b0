"""The learning dataset file format (`fvtree record`, `fvtree import-log`, read by `fvtree train`):
one row per tick.

A dataset is a NumPy .npz archive holding
  header    JSON text: {"format": "fvtree-recording", "version": 1, "feature_spec": {...},
            "columns": [...], "label_names": [...], "source": {tree, cell, scene, seeds},
            "label_info": {...}}  (label_info: e.g. the simulated scale's noise)
  t         (T,) float64, cell time of the tick (s), restarting at 0 for each run
  run       (T,) int32, index of the run the tick belongs to (`--runs`)
  segment   (T,) int32, the learning example the tick belongs to (a stirring trial), -1 if none
  features  (T, F) float32, `features.tick_features` of the tick
  label_<name>  (T,) one column per label (floats, or strings such as the substance)
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fvfiles.errors import FvtreeError
from fvfiles.npz_files import npz_problem
from perception.learning.features import check_spec

FORMAT = "fvtree-recording"
VERSION = 1

MAX_BYTES = 1 << 30  # a recording's arrays, uncompressed: hours of ticks take tens of MiB


class RecordingError(FvtreeError, ValueError):
    """A file is not a recording of this format and version."""


@dataclass
class Dataset:
    """Per-tick tactile features and labels of one or more recorded runs (the format above)."""

    header: dict
    t: np.ndarray
    run: np.ndarray
    segment: np.ndarray
    features: np.ndarray
    labels: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.t)

    def label(self, name: str) -> np.ndarray:
        if name not in self.labels:
            raise ValueError(f"the recording has no label {name!r} (it has: {', '.join(self.labels) or 'none'}); "
                             "record it from a scene that provides it")
        return self.labels[name]

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        header = {**self.header, "format": FORMAT, "version": VERSION, "label_names": sorted(self.labels)}
        with open(path, "wb") as f:  # np.savez_compressed would append .npz to a str path
            np.savez_compressed(f, header=np.array(json.dumps(header)), t=self.t, run=self.run,
                                segment=self.segment, features=self.features.astype(np.float32),
                                **{f"label_{k}": v for k, v in self.labels.items()})
        return path

    @classmethod
    def load(cls, path: str | Path) -> Dataset:
        """Read a recording; ValueError saying why if it is not one, is too large uncompressed
        (`MAX_BYTES`, from the zip directory and the .npy headers, before anything is inflated) or
        its features differ."""
        problem = npz_problem(path, MAX_BYTES) if zipfile.is_zipfile(path) else None
        if problem:
            raise RecordingError(f"not loaded: {problem}", str(path))
        try:
            data = np.load(path, allow_pickle=False)
            header = json.loads(str(data["header"]))
        except (OSError, ValueError, KeyError) as exc:
            raise RecordingError(f"not an fvtree recording ({exc})", str(path)) from None
        if header.get("format") != FORMAT or header.get("version") != VERSION:
            raise RecordingError(f"format {header.get('format')!r} version {header.get('version')!r}; "
                                 f"expected {FORMAT!r} version {VERSION}", str(path),
                                 hint="re-record it with this version's fvtree record")
        check_spec(header.get("feature_spec", {}), f"recording {path}")
        labels = {k[len("label_"):]: data[k] for k in data.files if k.startswith("label_")}
        return cls(header, data["t"], data["run"], data["segment"], data["features"].astype(float), labels)

    @classmethod
    def concatenate(cls, parts: list[Dataset], header: dict) -> Dataset:
        """Join recordings of several runs; segments are renumbered so they stay distinct."""
        offset, segments = 0, []
        for i, part in enumerate(parts):
            seg = np.where(part.segment >= 0, part.segment + offset, -1)
            segments.append(seg)
            offset = max(offset, int(seg.max()) + 1 if len(seg) else offset)
        names = set().union(*(p.labels for p in parts)) if parts else set()
        return cls(header, np.concatenate([p.t for p in parts]),
                   np.concatenate([np.full(len(p), i, np.int32) for i, p in enumerate(parts)]),
                   np.concatenate(segments).astype(np.int32), np.vstack([p.features for p in parts]),
                   {k: np.concatenate([p.labels[k] for p in parts]) for k in names})
