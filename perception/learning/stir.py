"""StirLearn: which substance a stick was stirred in, from what the fingers felt during one
stirring trial. A trial's feature vector summarises each per-tick signal - the marker
deviation of every grid cell, force, torque, object centroid, orientation, area and slip of
each finger - by its mean, its spread, its mean tick-to-tick change (texture) and the ratio of
the two (roughness); what depends on the sensor rather than the trial (the object's seen area
and place, tz's offset) is taken relative to the trial's start.

The paper's classifier is an MLP with three hidden layers of ten logistic units; the obvious
alternatives are trained and reported alongside. Trials of one recording are split 72/48 of 120 as
in the paper (stratified by substance); a recording of another session (another day's substances
and skin) tests a model fairly, as a lab would use it."""

from __future__ import annotations

import numpy as np
from sklearn.ensemble import RandomForestClassifier
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import classification_report, f1_score
from sklearn.model_selection import train_test_split
from sklearn.neighbors import KNeighborsClassifier
from sklearn.neural_network import MLPClassifier
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from perception.learning.dataset import Dataset
from perception.learning.features import GRID, MARKER_CHANNELS, columns
from perception.learning.models import TrainedModel

LABEL = "substance"
PAPER_MODEL = "mlp_3x10_logistic"
TEST_TRIALS = 48


FROM_START = (".orientation", ".cx", ".cy", ".tz")  # signals taken as their change since the trial's start
SHARE_OF_START = (".area",)  # signals taken as a share of their value at the trial's start
START_TICKS = 5  # the trial's start: the median of its first ticks, not one noisy tick


def _signal_matrix(rows: np.ndarray) -> np.ndarray:
    """(T, S) per-tick signals: marker deviation per cell, then the per-finger summaries. What
    belongs to the sensor rather than to the trial is taken relative to the trial's start: the
    stick's angle and place in the fingers carry over from earlier trials, the proximity mask sees
    a share of the stick's area that depends on the sensor (0.61-0.67), and tz's offset depends
    on which markers the sensor loses."""
    cells = GRID[0] * GRID[1]
    per_finger = cells * len(MARKER_CHANNELS) + (len(columns()) // 2 - cells * len(MARKER_CHANNELS))
    out = []
    for finger in range(2):
        base = finger * per_finger
        grid = rows[:, base:base + cells * len(MARKER_CHANNELS)].reshape(len(rows), cells, len(MARKER_CHANNELS))
        out += [np.hypot(grid[:, :, 0], grid[:, :, 1]), rows[:, base + cells * len(MARKER_CHANNELS):base + per_finger]]
    signals = np.hstack(out)
    names, start = _summary_names(), np.median(signals[:START_TICKS], axis=0)
    moved = [i for i, name in enumerate(names) if name.endswith(FROM_START)]
    signals[:, moved] -= start[moved]
    share = [i for i, name in enumerate(names) if name.endswith(SHARE_OF_START)]
    signals[:, share] = signals[:, share] / np.maximum(start[share], 1e-6) - 1.0
    return signals


def _summary_names() -> list[str]:
    """Names of the `_signal_matrix` columns."""
    cells = [f"cell{r}{c}" for r in range(GRID[1]) for c in range(GRID[0])]
    names = columns()
    summary = [n.split(".", 1)[1] for n in names[: len(names) // 2] if ".cell" not in n]
    return [f"{f}.{n}" for f in ("left", "right") for n in cells + summary]


def trial_features(rows: np.ndarray) -> np.ndarray:
    """The feature vector of one stirring trial from its per-tick feature rows (T, F): each
    signal's mean, spread, texture (mean tick-to-tick change) and roughness (texture over spread).
    Roughness does not scale with the skin's stiffness, the dip's depth or the batch's drag, which
    vary between sessions, and tells a fast grain (sugar) from a slow one (flour)."""
    rows = np.asarray(rows, float)
    if len(rows) < 3:
        raise ValueError(f"a stirring trial needs at least 3 ticks, got {len(rows)}")
    s = _signal_matrix(rows)
    spread, texture = s.std(axis=0), np.abs(np.diff(s, axis=0)).mean(axis=0)
    return np.concatenate([s.mean(axis=0), spread, texture, texture / (spread + 1e-9)])


def trials(rec: Dataset) -> tuple[np.ndarray, np.ndarray]:
    """(X, y): one row per stirring trial (segment) of the recording, labelled with the
    substance the stick was in for most of it."""
    labels = rec.label(LABEL)
    x, y = [], []
    for seg in np.unique(rec.segment[rec.segment >= 0]):
        mask = rec.segment == seg
        values, counts = np.unique(labels[mask], return_counts=True)
        label = str(values[np.argmax(counts)])
        if label == "none":
            continue  # stirred in the air
        x.append(trial_features(rec.features[mask]))
        y.append(label)
    if not x:
        raise ValueError("the recording holds no stirring trials (record a tree that uses `stir`)")
    return np.array(x), np.array(y)


def classifiers(seed: int = 0) -> dict:
    """The paper's MLP and the obvious alternatives, each behind a standard scaler."""
    def scaled(model):
        return make_pipeline(StandardScaler(), model)
    return {
        # A little L2 weight decay (alpha) keeps the small-data MLP out of poor local minima.
        PAPER_MODEL: scaled(MLPClassifier((10, 10, 10), activation="logistic", solver="lbfgs", alpha=0.01,
                                          max_iter=5000, random_state=seed)),
        "logistic_regression": scaled(LogisticRegression(max_iter=5000)),
        "svm_rbf": scaled(SVC()),
        "random_forest": scaled(RandomForestClassifier(200, random_state=seed)),
        "knn_5": scaled(KNeighborsClassifier(5)),
    }


def split(y: np.ndarray, seed: int = 0, test_trials: int = TEST_TRIALS) -> tuple[np.ndarray, np.ndarray]:
    """Indices (train, test), stratified by substance; 48 test trials as in the paper (or 40 %)."""
    n_test = test_trials if len(y) > test_trials * 1.5 else max(len(set(y)), round(0.4 * len(y)))
    return train_test_split(np.arange(len(y)), test_size=n_test, stratify=y, random_state=seed)


def evaluate(model, x_train, y_train, x_test, y_test) -> dict:
    model.fit(x_train, y_train)
    predicted = model.predict(x_test)
    return {"f1": float(f1_score(y_test, predicted, average="macro")),
            "table": classification_report(y_test, predicted, digits=2, zero_division=0),
            "per_class": classification_report(y_test, predicted, output_dict=True, zero_division=0)}


def train_stir(rec: Dataset, seed: int = 0, test_session: Dataset | None = None) -> tuple[TrainedModel, dict]:
    """Train every classifier on the training trials, report each on the held-out ones (every
    trial of `test_session` when given, else the paper's split of `rec`), and return the paper's
    MLP as the model."""
    x, y = trials(rec)
    if test_session is None:
        train, test = split(y, seed)
        x_train, y_train, x_test, y_test = x[train], y[train], x[test], y[test]
    else:
        (x_test, y_test), x_train, y_train = trials(test_session), x, y
    models = classifiers(seed)
    results = {name: evaluate(m, x_train, y_train, x_test, y_test) for name, m in models.items()}
    report = {"train_trials": len(y_train), "test_trials": len(y_test), "saved": PAPER_MODEL,
              "tested_on": "another session" if test_session is not None else "held-out trials of the session",
              "classes": sorted(set(y)), "models": results}
    info = {"label": LABEL, "classes": sorted(set(y)), "report": {k: v for k, v in report.items() if k != "models"},
            "f1": results[PAPER_MODEL]["f1"], "source": rec.header.get("source", {})}
    return TrainedModel("stir", models[PAPER_MODEL], info), report


def classify(model: TrainedModel, rows: np.ndarray) -> tuple[str, dict[str, float]]:
    """(substance, probability per substance) for one trial's per-tick feature rows."""
    estimator = model.estimator
    p = estimator.predict_proba(trial_features(rows)[None, :])[0]
    probabilities = {str(c): float(v) for c, v in zip(estimator.classes_, p)}
    return max(probabilities, key=probabilities.get), probabilities


def plot_stir(report: dict, path) -> object:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(report["models"])
    f1 = [report["models"][n]["f1"] for n in names]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.barh(names, f1, color=["C3" if n == report["saved"] else "C0" for n in names])
    ax.set(xlim=(0, 1.0), xlabel="macro f1 on held-out trials",
           title=f"StirLearn: {report['train_trials']} train / {report['test_trials']} test trials "
                 f"({report['tested_on']})")
    for i, v in enumerate(f1):
        ax.text(v, i, f" {v:.3f}", va="center")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
