"""StirLearn workflow: record stirring trials in the three bowls, cut them into trials, train
the paper's MLP and the alternatives; the paper's 72/48 split."""

from __future__ import annotations

import numpy as np
import pytest

from perception.learning.dataset import Recording
from perception.learning.stir import PAPER_MODEL, split, train_stir, trials


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
    assert report["models"][PAPER_MODEL]["f1"] >= 0.9
    assert set(report["models"]) >= {PAPER_MODEL, "logistic_regression", "svm_rbf", "random_forest"}
    assert list(model.estimator.classes_) == ["flour", "peas", "sugar"]


def test_the_paper_split_holds_out_48_of_120_trials_stratified():
    y = np.repeat(["flour", "sugar", "peas"], 40)
    train, test = split(y)
    assert len(train) == 72 and len(test) == 48
    assert all((y[test] == s).sum() == 16 for s in ("flour", "sugar", "peas"))
