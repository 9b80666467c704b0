"""Model files: a fitted scikit-learn estimator saved with what it needs to be used safely.

A model file (joblib) holds {"format": "fvtree-model", "version": 1, "kind": "force" | "stir",
"feature_spec": ..., "estimator": ..., "info": {...}}. Loading checks the kind and that the
features the model was trained on are the ones this code computes, and says what to do if not.
Model files are pickles: load only models you made or trust.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import joblib

from perception.errors import FvtreeError
from perception.learning.features import check_spec, feature_spec

FORMAT = "fvtree-model"
VERSION = 1
KINDS = ("force", "stir")


class ModelError(FvtreeError, ValueError):
    """A model file is missing, of the wrong kind or made for other features."""


@dataclass
class TrainedModel:
    kind: str
    estimator: Any
    info: dict  # training report, labels, data source

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        joblib.dump({"format": FORMAT, "version": VERSION, "kind": self.kind, "feature_spec": feature_spec(),
                     "estimator": self.estimator, "info": self.info}, path, compress=3)
        return path


def load_model(path: str | Path, kind: str) -> TrainedModel:
    """Load a model of `kind`; ModelError with an actionable message otherwise."""
    path = Path(path)
    if not path.exists():
        raise ModelError(f"no model file at {path}: train one with `fvtree train {kind} DATA --out {path}`")
    try:
        data = joblib.load(path)
    except Exception as exc:  # noqa: BLE001 - unpickling fails in many ways
        raise ModelError(f"{path}: cannot read the model ({type(exc).__name__}: {exc}); retrain it") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ModelError(f"{path}: not an fvtree model file")
    if data.get("version") != VERSION:
        raise ModelError(f"{path}: model file version {data.get('version')}, expected {VERSION}; retrain it")
    if data.get("kind") != kind:
        raise ModelError(f"{path}: a {data.get('kind')!r} model, but a {kind!r} model is needed")
    try:
        check_spec(data.get("feature_spec", {}), f"model {path}")
    except ValueError as exc:
        raise ModelError(str(exc)) from None
    return TrainedModel(kind, data["estimator"], data.get("info", {}))
