"""Pixel-mode runs recorded beside their truth: every tick, what the scene put on each fingertip
(the contact model's loads, object and slip, and the noise-free marker field it implies) and what
the real FingerVision pipeline made of the rendered frame. Read by `errors.py`."""

from __future__ import annotations

import dataclasses
import shutil
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from assembly.design.model import DesignModel
from assembly.run.options import RunOptions
from assembly.run.session import Run, world_of
from drivers.cell import Cell
from drivers.cell_file import resolve_cell_path
from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.scenes.scene_file import scene_file_of
from perception.sensor_profile import DEFAULT_PROFILE, NUMBERS, load_profile
from perception.state import FINGERS, TactileState


@dataclass(frozen=True)
class Tick:
    """One finger on one tick: truth (contact and noise-free markers) and the pipeline's state."""

    contact: FingerContact
    position: np.ndarray  # (N, 2) px, noise-free marker centres, in the pipeline's marker order
    size: np.ndarray  # (N,) px
    state: TactileState


@dataclass
class PixelRun:
    """The ticks of one run, per finger, and how the run ended."""

    tree: str
    status: str
    ticks: dict[str, list[Tick]]
    period: float


def first_element_only(tree: Path, out_dir: Path) -> Path:
    """A copy of an assembly tree that builds only the first element of its design's build order."""
    doc = yaml.safe_load(tree.read_text())
    design = (tree.parent / doc["design"]).resolve()
    first = DesignModel.load(design).build_order()[0]
    # copied beside the copy: a tree reads its includes and its design (with the design's scene file) from its
    # own folder only
    scene = scene_file_of(design)
    scene_rel = Path(doc["design"]).with_name(scene.name)
    for rel in [*(doc.get("include") or []), doc["design"], *([scene_rel] if scene.exists() else [])]:
        (out_dir / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(tree.parent / rel, out_dir / rel)

    def restrict(node) -> None:
        if isinstance(node, dict):
            if "for_each_element" in node:
                node["elements"] = [first]
            for value in node.values():
                restrict(value)
        elif isinstance(node, list):
            for value in node:
                restrict(value)

    restrict(doc["root"])
    short = out_dir / tree.name
    short.write_text(yaml.safe_dump(doc, sort_keys=False))
    return short


def _order(model_origin: np.ndarray, pipeline_origin: np.ndarray) -> np.ndarray:
    """For each pipeline marker, the index of the model marker it was calibrated on (nearest)."""
    d = np.linalg.norm(pipeline_origin[:, None, :] - model_origin[None, :, :], axis=2)
    return d.argmin(axis=1)


def record(tree: Path, seed: int = 0, max_time: float = 120.0) -> PixelRun:
    """Run `tree` in pixel mode on the simulated cell and record every tick beside its truth."""
    sensor_cfg = dict(yaml.safe_load(resolve_cell_path("sim").read_text()).get("sensor") or {})
    profile = load_profile(sensor_cfg.pop("profile", DEFAULT_PROFILE))
    numbers = {k: sensor_cfg.pop(k) for k in list(sensor_cfg) if k in NUMBERS}
    profile = dataclasses.replace(profile, **numbers)
    models = {f: SensorModel(f, profile, **{**sensor_cfg, "noise_px": 0.0, "pipeline_errors": False}) for f in FINGERS}
    ticks: dict[str, list[Tick]] = {f: [] for f in FINGERS}
    orders: dict[str, np.ndarray] = {}

    def sense(cell: Cell) -> Mapping[str, TactileState]:
        contacts = world_of(cell).contacts()  # what the frames about to be rendered show
        states = cell.sense()
        for f in FINGERS:
            truth = models[f].state(contacts[f], 0.0).markers
            if f not in orders:
                orders[f] = _order(truth.origin, states[f].markers.origin)
            idx = orders[f]
            ticks[f].append(Tick(dataclasses.replace(contacts[f]), truth.position[idx], truth.size[idx], states[f]))
        return states

    options = RunOptions(seed=seed, perception="pixels", max_time=max_time, runs_dir=None, record=False,
                         plots=False, quiet=True, supervised=False)
    with Run(tree, options, sense=sense) as run:
        result = run.loop()
    return PixelRun(tree.name, result.status, ticks, 1.0 / run.doc.tick_hz)
