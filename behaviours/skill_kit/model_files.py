"""Learned model files for skills: where they are found and when they are loaded.

A model path a tree gives is relative to the file the node is written in (never the working
directory); `..` and absolute paths are allowed, since a model file holds plain arrays that are
checked whole, sized before they are inflated, and cannot run code (`perception.learning.models`). A skill's default model ships
with the project and is relative to its root. The model is loaded and checked when the tree is
validated (`check_model`) and again at setup, before the first tick; never during a tick.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from behaviours.skill_kit.base import Skill
from perception.learning.models import ModelError, TrainedModel, check_model_file, load_model

PROJECT_ROOT = Path(__file__).resolve().parents[2]


def resolve_model_path(path: str, base: Path) -> Path:
    """`path` (from a file in the directory `base`) as an absolute path."""
    return (base / Path(path).expanduser()).resolve()


def check_model(skill: type, params: dict[str, Any], given: dict[str, Any], tree_file: str) -> dict[str, Any]:
    """The resolved params of a skill node with its model path made absolute (a path the tree
    gave: from the tree file's directory; the skill's default: from the project root), after
    checking the model file as loading it would (without scikit-learn); ModelError otherwise. Skills without a model: `params`."""
    if not issubclass(skill, UsesModel):
        return params
    base = Path(tree_file).resolve().parent if "model" in given else PROJECT_ROOT
    path = resolve_model_path(params["model"], base)
    check_model_file(path, skill.MODEL_KIND)
    return {**params, "model": str(path)}


class UsesModel(Skill):
    """A skill (a base beside `ProgramSkill`) with a `model` param naming a model file of kind
    `MODEL_KIND`: the file is loaded in `setup`, before the first tick, because reading a model (and
    importing scikit-learn) takes far longer than a tick and a stalled tick trips the arm's watchdog.
    The tree loader has made the path absolute and checked the file (`check_model`); one that went
    bad since leaves `model` None and the reason in `model_error`, for the skill to report."""

    MODEL_KIND: str
    model: TrainedModel | None
    model_error: str  # why `model` is None

    def setup(self, **kwargs: Any) -> None:
        super().setup(**kwargs)
        try:
            self.model, self.model_error = load_model(resolve_model_path(self.p.model, PROJECT_ROOT),
                                                      self.MODEL_KIND), ""
        except ModelError as exc:
            self.model, self.model_error = None, str(exc)
