"""Marker logs of other FingerVision software (BlobMoves: per frame, per marker [Pox, Poy, So,
DPx, DPy, DS] px) become recordings that `fvtree train force` learns from, holding out whole
trials; malformed logs are refused naming the file and the frame."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from assembly.cli import main
from perception.learning.blobmoves import import_logs, read_trial
from perception.learning.dataset import Dataset

GRID_X, GRID_Y = np.meshgrid(np.linspace(40, 280, 6), np.linspace(30, 210, 4))
ORIGINS = np.column_stack([GRID_X.ravel(), GRID_Y.ravel()])  # 24 markers


def frames(load: float, n: int, rng: np.random.Generator) -> list:
    """A trial's BlobMoves: the skin shears along x with the load, more near the bottom of the
    image, markers grow where it presses; 0.05 px tracking noise."""
    shear = 0.6 * load * (0.5 + ORIGINS[:, 1] / 240.0)
    out = []
    for _ in range(n):
        d = np.column_stack([shear, 0.1 * load * np.ones(len(ORIGINS))]) + rng.normal(0, 0.05, (len(ORIGINS), 2))
        grow = 0.2 * load + rng.normal(0, 0.05, len(ORIGINS))
        out.append(np.column_stack([ORIGINS, np.full(len(ORIGINS), 8.0), d, grow]).round(4).tolist())
    return out


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> list[Path]:
    """Twelve trials of 20 frames with loads 0.5-6 N, JSON and YAML."""
    folder = tmp_path_factory.mktemp("logs")
    rng = np.random.default_rng(0)
    paths = []
    for i, load in enumerate(np.linspace(0.5, 6.0, 12)):
        trial = {"load": float(load), "finger": "right", "frames": frames(float(load), 20, rng)}
        path = folder / f"trial_{i:02d}.{'yaml' if i % 3 == 0 else 'json'}"
        path.write_text(yaml.safe_dump(trial) if path.suffix == ".yaml" else json.dumps(trial))
        paths.append(path)
    return paths


def test_logs_become_a_recording_with_one_segment_per_trial(logs, tmp_path):
    rec = import_logs(logs)
    assert len(rec) == 240 and sorted(set(rec.segment)) == list(range(12))
    assert np.allclose(rec.labels["scale_force"][rec.segment == 11], 6.0)
    assert "substance" not in rec.labels
    right = [i for i, c in enumerate(rec.header["columns"]) if c.startswith("right.cell")]
    left = [i for i, c in enumerate(rec.header["columns"]) if c.startswith("left.cell")]
    assert np.abs(rec.features[:, right]).max() > 1.0 and not rec.features[:, left].any()
    again = Dataset.load(rec.save(tmp_path / "logs.npz"))
    assert again.header["groups"] == "segment" and len(again) == 240


def test_force_learns_from_imported_logs_holding_out_whole_trials(logs, tmp_path, capsys):
    data = tmp_path / "logs.npz"
    assert main(["import-log", *map(str, logs), "--out", str(data)]) == 0
    assert "(12 trials, 240 frames)" in capsys.readouterr().out
    assert main(["train", "force", str(data), "--out", str(tmp_path / "force.npz")]) == 0
    out = capsys.readouterr().out
    report = json.loads((tmp_path / "force.report.json").read_text())
    assert report["r2"] > 0.95 and report["presses"] == 12
    held_out = report["held_out_groups"]
    assert [g["group"] for g in held_out] == [3, 7, 11] and all(g["ticks"] == 20 for g in held_out)
    assert [round(g["mean_load"], 2) for g in held_out] == [2.0, 4.0, 6.0]
    assert "per held-out press or trial:" in out and "mean load    6.000 N" in out


def test_the_public_calibration_layout_is_read_with_its_mass_in_grams(tmp_path):
    path = tmp_path / "calib_584.20_15.00_0.00_0.00.json"
    path.write_text(json.dumps({"mass": 584.2, "fx": 1.48, "frame_width": 320, "frame_height": 240,
                                "MoveData": [{"BlobMoves": f, "id": i}
                                             for i, f in enumerate(frames(5.7, 3, np.random.default_rng(1)))]}))
    trial = read_trial(path)
    assert trial["load"] == pytest.approx(0.5842 * 9.81) and trial["markers"].shape == (3, 24, 6)
    assert trial["finger"] == "left" and trial["image_size"] == (320, 240)


def _bad(tmp_path: Path, change) -> Path:
    trial = {"load": 1.0, "frames": frames(1.0, 5, np.random.default_rng(2))}
    change(trial)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(trial).replace('"NAN"', "NaN"))
    return path


@pytest.mark.parametrize("change, message", [
    (lambda t: t["frames"][3].pop(), "bad.json: frames[3]: 23 markers where the first frame has 24"),
    (lambda t: t.pop("load"), "bad.json: no load and no label: give 'load' (N) or 'mass' (g)"),
    (lambda t: t["frames"][2][5].__setitem__(3, "abc"), "bad.json: frames[2]: marker 5: DPx must be a finite number"),
    (lambda t: t["frames"][1][0].__setitem__(4, "NAN"), "not a JSON marker log (NaN is not a number"),
    (lambda t: t["frames"][4].__setitem__(0, [1, 2, 3]), "frames[4]: marker 0 must be [Pox, Poy, So, DPx, DPy, DS]"),
    (lambda t: t.__setitem__("load", True), "bad.json: load: load must be a finite number"),
    (lambda t: t.__setitem__("frames", []), "'frames' must be a non-empty list of frames"),
])
def test_malformed_logs_are_refused_with_the_file_and_frame(tmp_path, capsys, change, message):
    path = _bad(tmp_path, change)
    assert main(["import-log", str(path), "--out", str(tmp_path / "x.npz")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x.npz").exists()
