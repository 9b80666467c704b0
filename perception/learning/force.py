"""ForceLearn: the force an object is pressed with, in newtons, from the pooled marker field,
by kernel ridge regression with an RBF kernel; regularisation and kernel width by grouped
cross-validation (whole presses are held out together, so neighbouring ticks do not leak)."""

from __future__ import annotations

import numpy as np
from sklearn.kernel_ridge import KernelRidge
from sklearn.metrics import mean_squared_error, r2_score
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from perception.learning.dataset import Dataset
from perception.learning.features import marker_columns
from perception.learning.models import TrainedModel

LABEL = "scale_force"
GRID = {"kernelridge__alpha": [1e-3, 1e-2, 1e-1], "kernelridge__gamma": [1e-3, 3e-3, 1e-2]}


def press_ids(rec: Dataset, threshold: float = 0.5) -> np.ndarray:
    """Index of the press each tick belongs to: a new press starts where the scale reading
    rises above `threshold` N (the ticks before the first press form press 0 too)."""
    pressed = rec.label(LABEL).astype(float) > threshold
    rising = pressed & ~np.r_[False, pressed[:-1]]
    rising[np.r_[True, rec.run[1:] != rec.run[:-1]]] = False
    return np.maximum(np.cumsum(rising) - 1, 0)


def trial_groups(rec: Dataset) -> np.ndarray:
    """The group of each tick that is held out whole: its trial for imported marker logs (each
    log one segment), else its press."""
    return rec.segment if rec.header.get("groups") == "segment" else press_ids(rec)


def per_group(y: np.ndarray, predicted: np.ndarray, groups: np.ndarray) -> list[dict]:
    """MSE and R2 of each held-out press or trial (R2 only where the load varies within it),
    with its mean load: where a model is off, and for which loads."""
    out = []
    for g in np.unique(groups):
        mine = groups == g
        varies = np.ptp(y[mine]) > 1e-9
        out.append({"group": int(g), "ticks": int(mine.sum()), "mean_load": float(y[mine].mean()),
                    "mse": float(mean_squared_error(y[mine], predicted[mine])),
                    "r2": float(r2_score(y[mine], predicted[mine])) if varies else None})
    return out


def split_presses(presses: np.ndarray, test_every: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Masks (train, test): every `test_every`-th press is held out for testing."""
    test = presses % test_every == test_every - 1
    return ~test, test


def fit_force(x: np.ndarray, y: np.ndarray, groups: np.ndarray, max_samples: int = 600, seed: int = 0):
    """Kernel ridge regression with hyper-parameters chosen by grouped cross-validation, on at
    most `max_samples` rows (the kernel matrix grows with their square)."""
    rng = np.random.default_rng(seed)
    keep = np.sort(rng.choice(len(y), min(max_samples, len(y)), replace=False))
    folds = min(4, len(np.unique(groups[keep])))
    if folds < 2:
        raise ValueError("need at least two presses to cross-validate; record more")
    search = GridSearchCV(make_pipeline(StandardScaler(), KernelRidge(kernel="rbf")), GRID,
                          cv=GroupKFold(folds), scoring="neg_mean_squared_error")
    search.fit(x[keep], y[keep], groups=groups[keep])
    return search.best_estimator_, {k.split("__")[1]: v for k, v in search.best_params_.items()}


def train_force(rec: Dataset, max_samples: int = 600, seed: int = 0) -> tuple[TrainedModel, dict]:
    """Train on 3 of every 4 presses, test on the rest; returns the model and the report."""
    x = rec.features[:, marker_columns()]
    y = rec.label(LABEL).astype(float)
    presses = trial_groups(rec)
    train, test = split_presses(presses)
    estimator, params = fit_force(x[train], y[train], presses[train], max_samples, seed)
    predicted = estimator.predict(x[test])
    report = {"presses": int(presses.max()) + 1, "train_ticks": int(train.sum()), "test_ticks": int(test.sum()),
              "held_out_groups": per_group(y[test], predicted, presses[test]),
              "hyper_parameters": params,
              "mse": float(mean_squared_error(y[test], predicted)),
              "rmse": float(np.sqrt(mean_squared_error(y[test], predicted))),
              "r2": float(r2_score(y[test], predicted)),
              "scale_noise_std": rec.header.get("label_info", {}).get(LABEL, {}).get("noise_std")}
    if "true_force" in rec.labels:
        truth = rec.labels["true_force"].astype(float)[test]
        report["rmse_vs_true_force"] = float(np.sqrt(mean_squared_error(truth, predicted)))
    report["test"] = {"measured": y[test].tolist(), "predicted": predicted.tolist()}
    info = {"label": LABEL, "unit": "N", "columns": "marker grid (dx, dy, ds per cell)", "report": report,
            "source": rec.header.get("source", {})}
    return TrainedModel("force", estimator, info), report


def predict_force(model: TrainedModel, features: np.ndarray) -> float:
    """Force (N) for one tick's feature vector."""
    return float(model.estimator.predict(features[marker_columns()][None, :])[0])
