"""Learned model files for skills: where they are found (a relative path is looked up from the
working directory first, then from the project root, so demo trees run from anywhere in the repo)
and when they are loaded (at tree setup, never during a tick)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from perception.learning.models import ModelError, load_model

PROJECT_ROOT = Path(__file__).resolve().parents[1]


def resolve_model_path(path: str) -> Path:
    candidate = Path(path)
    if candidate.is_absolute() or candidate.exists():
        return candidate
    in_project = PROJECT_ROOT / candidate
    return in_project if in_project.exists() else candidate


class UsesModel:
    """Mixin for a skill with a `model` param naming a model file of kind `MODEL_KIND`: the file is
    loaded in `setup`, before the first tick, because unpickling a model (and importing
    scikit-learn) takes far longer than a tick and a stalled tick trips the arm's watchdog. An
    unusable file leaves `model` None and the reason in `model_error`, for the skill to report."""

    MODEL_KIND: str

    def setup(self, **kwargs: Any) -> None:
        super().setup(**kwargs)
        try:
            self.model, self.model_error = load_model(resolve_model_path(self.p.model), self.MODEL_KIND), None
        except ModelError as exc:
            self.model, self.model_error = None, str(exc)
