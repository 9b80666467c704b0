"""StirLearn workflow: record stirring trials in the three bowls, cut them into trials, train
the paper's MLP and the alternatives; the paper's 72/48 split."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from assembly.cli import main
from drivers.sim.scenes.stir import SUBSTANCES, session_batch
from perception.learning.dataset import Recording
from perception.learning.stir import PAPER_MODEL, split, train_stir, trials

TREES = Path(__file__).resolve().parents[1] / "trees"


@pytest.fixture(scope="module")
def stirred(record_shortened) -> Recording:
    """Sixteen trials per bowl (each movement twice)."""
    return record_shortened("record_stir", (40, 16))


def test_the_recording_is_cut_into_labelled_trials(stirred):
    x, y = trials(stirred)
    assert len(x) == 48 and sorted(set(y)) == ["flour", "peas", "sugar"]
    assert (y == "peas").sum() == 16 and np.isfinite(x).all()


def test_stirlearn_tells_the_substances_apart(stirred):
    model, report = train_stir(stirred)
    assert report["test_trials"] == 19 and report["train_trials"] == 29
    assert report["models"][PAPER_MODEL]["f1"] >= 0.8  # 29 training trials of one session, with the pipeline's errors
    assert set(report["models"]) >= {PAPER_MODEL, "logistic_regression", "svm_rbf", "random_forest"}
    assert list(model.estimator.classes_) == ["flour", "peas", "sugar"]


def test_the_paper_split_holds_out_48_of_120_trials_stratified():
    y = np.repeat(["flour", "sugar", "peas"], 40)
    train, test = split(y)
    assert len(train) == 72 and len(test) == 48
    assert all((y[test] == s).sum() == 16 for s in ("flour", "sugar", "peas"))


@pytest.fixture(scope="module")
def another_session(tmp_path_factory) -> Recording:
    """Eight trials per bowl recorded in session 1 (another batch of each substance, another skin)."""
    from assembly.recording import record

    tree = tmp_path_factory.mktemp("session1") / "record_stir.yaml"
    tree.write_text((TREES / "record_stir.yaml").read_text().replace("times: 40", "times: 8"))
    return Recording.load(record(tree, tree.with_suffix(".npz"), seed=1))


def test_sessions_differ_in_their_substances_and_skin_and_repeat_with_their_seed():
    assert session_batch(0) == session_batch(0)
    (first, *skin0), (second, *skin1) = session_batch(0), session_batch(1)
    assert skin0 != skin1 and all(first[s] != second[s] for s in SUBSTANCES)


def test_a_model_is_tested_on_another_session_and_the_classifiers_differ(stirred, another_session):
    _, report = train_stir(stirred, test_session=another_session)
    assert report["tested_on"] == "another session"
    assert report["train_trials"] == 48 and report["test_trials"] == 24
    f1 = {name: result["f1"] for name, result in report["models"].items()}
    assert len({round(v, 3) for v in f1.values()}) > 1, f1
    assert all(0.0 <= v <= 1.0 for v in f1.values())


def test_train_takes_another_sessions_recording_for_stirlearn_only(stirred, another_session, tmp_path, capsys):
    data, other = stirred.save(tmp_path / "a.npz"), another_session.save(tmp_path / "b.npz")
    assert main(["train", "stir", str(data), "--test", str(other), "--out", str(tmp_path / "m.npz")]) == 0
    assert "48 training / 24 test trials, tested on another session" in capsys.readouterr().out
    assert main(["train", "force", str(data), "--test", str(other), "--out", str(tmp_path / "f.npz")]) == 2
    assert "--test (a recording of another session) is for StirLearn" in capsys.readouterr().err


def test_a_grid_cell_without_markers_reports_the_skin_next_to_it():
    """A sensor whose calibration found no marker in a corner cell (the pipeline's marker list is
    its own) pools the nearest markers there, not a still cell of zeros."""
    from drivers.sim.models.fingervision_model import FingerContact, SensorModel
    from perception.learning.features import GRID, MARKER_CHANNELS, pooled_markers
    from perception.state import MarkerField

    field = SensorModel("left", noise_px=0.0).state(FingerContact(5.0, np.array([2.0, 1.0])), 0.0).markers
    full = pooled_markers(field).reshape(GRID[0] * GRID[1], len(MARKER_CHANNELS))
    w, h = field.image_size
    corner = (field.origin[:, 0] >= 2 * w / 3) & (field.origin[:, 1] < h / 3)  # cell 02, top right
    keep = ~corner
    partial = MarkerField(field.origin[keep], field.position[keep], field.origin_size[keep], field.size[keep],
                          field.valid[keep], field.image_size)
    pooled = pooled_markers(partial).reshape(GRID[0] * GRID[1], len(MARKER_CHANNELS))
    assert corner.sum() >= 1 and np.abs(pooled[2]).sum() > 0.5 * np.abs(full[2]).sum()
    assert np.allclose(np.delete(pooled, 2, axis=0), np.delete(full, 2, axis=0))


def test_a_trial_is_read_the_same_whatever_share_of_the_object_a_sensor_sees():
    """The object's area, centroid and angle count from the trial's start: the share of the stick a
    proximity mask sees (0.63-0.70 by sensor in pixel mode) and where it puts it belong to the
    sensor, not to the substance."""
    from perception.learning.features import columns
    from perception.learning.stir import trial_features

    rng = np.random.default_rng(0)
    rows = rng.normal(size=(40, len(columns())))
    shifted = rows.copy()
    for i, name in enumerate(columns()):
        if name.endswith((".area", ".cx", ".cy", ".orientation")):
            shifted[:, i] += 0.05
    assert np.allclose(trial_features(rows), trial_features(shifted))


def test_a_dip_gets_the_same_fill_however_long_the_run_took_before_it():
    """Each dip's packing and grain come from a stream of their own: a run whose ticks differ
    (pixel against signals mode) still stirs the same fill in its n-th dip."""
    from drivers.sim.scenes.stir import StirScene

    class Arm:
        def __init__(self):
            self.p = np.array([0.0, 0.3, 0.5, np.pi, 0.0, 0.0])

        def pose(self):
            return self.p

    class Held(StirScene):
        def carry(self, dt):
            self._dt = dt
            return 60.0

    def second_dip(ticks_in_first: int) -> np.ndarray:
        arm = Arm()
        scene = Held(arm, None, seed=4)
        for z, ticks in ((0.44, ticks_in_first), (0.5, 3), (0.44, 1)):  # dip, lift, dip again
            arm.p = np.r_[0.0, 0.3 + 0.001 * ticks, z, np.pi, 0.0, 0.0]
            for i in range(ticks):
                arm.p = arm.p + np.r_[0.001 * (i % 2), 0.0, 0.0, 0.0, 0.0, 0.0]  # stirring: texture draws
                scene.step(1 / 30)
        assert scene.stirred == ["sugar", "sugar"]
        return scene._factors

    assert np.array_equal(second_dip(5), second_dip(40))
