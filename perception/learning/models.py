"""Model files: a fitted model saved as plain arrays, in a format that cannot execute code.

A model file (`.npz`, read with `allow_pickle=False`) holds a JSON header (`header`: {"format":
"fvtree-model", "version": 2, "kind": "force" | "stir", "feature_spec", "estimator": what was
fitted and its hyper-parameters, "info": the training report}) and the fitted parameters as
numeric (or, for class names, string) arrays. Loading checks the kind, that the features the
model was trained on are the ones this code computes, and the shape of every array, then puts
the parameters back into the scikit-learn estimators they came from, so predictions are those
of the trained model. A pickle (the joblib files of version 1) is refused, never opened.

Estimators: ForceLearn's scaler + kernel ridge (RBF), StirLearn's scaler + MLP classifier.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fvfiles.errors import FvtreeError
from fvfiles.npz_files import npz_problem
from perception.learning.features import check_spec, feature_spec

if TYPE_CHECKING:  # scikit-learn loads with the first model made (seconds): `fvtree validate` only checks the file
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

FORMAT = "fvtree-model"
VERSION = 2
KINDS = ("force", "stir")
SUFFIX = ".npz"
MAX_BYTES = 64 << 20  # a model file, or its arrays uncompressed, larger than this is refused before it is read


class ModelError(FvtreeError, ValueError):
    """A model file is missing, of the wrong kind, made for other features or not a model file."""


def _scaler_arrays(scaler: StandardScaler) -> dict[str, np.ndarray]:
    return {"scaler_mean": scaler.mean_, "scaler_scale": scaler.scale_, "scaler_var": scaler.var_}


def _scaler(arrays: dict[str, np.ndarray], n: int) -> StandardScaler:
    from sklearn.preprocessing import StandardScaler

    scaler = StandardScaler()
    scaler.mean_, scaler.scale_, scaler.var_ = (arrays[k] for k in ("scaler_mean", "scaler_scale", "scaler_var"))
    scaler.n_features_in_, scaler.n_samples_seen_ = n, 0
    return scaler


def export_estimator(estimator: Pipeline) -> tuple[dict, dict[str, np.ndarray]]:
    """(description, arrays) of a fitted scaler + kernel ridge or scaler + MLP pipeline."""
    from sklearn.kernel_ridge import KernelRidge
    from sklearn.neural_network import MLPClassifier

    scaler, model = estimator[0], estimator[-1]
    arrays = _scaler_arrays(scaler)
    if isinstance(model, KernelRidge) and model.kernel == "rbf":
        arrays.update(dual_coef=model.dual_coef_, x_fit=model.X_fit_)
        return {"type": "kernel_ridge_rbf", "alpha": float(model.alpha), "gamma": float(model.gamma)}, arrays
    if isinstance(model, MLPClassifier):
        for i, (w, b) in enumerate(zip(model.coefs_, model.intercepts_)):
            arrays[f"coef_{i}"], arrays[f"intercept_{i}"] = w, b
        arrays["classes"] = np.asarray(model.classes_).astype(str)
        return {"type": "mlp_classifier", "activation": model.activation, "out_activation": model.out_activation_,
                "layers": len(model.coefs_)}, arrays
    raise ValueError(f"cannot save a {type(model).__name__} model as plain arrays")


def _checked(description: Any, arrays: dict[str, np.ndarray], path: Path) -> dict[str, Any]:
    """The parts of the estimator a description and its arrays make, every shape checked (without
    scikit-learn, so that a tree's model is checked without importing it)."""
    if not isinstance(description, dict):
        raise ModelError(f"{path}: the header does not describe an estimator; retrain it")
    kind = description.get("type")
    try:
        n = arrays["scaler_mean"].shape[0]
        for key in ("scaler_mean", "scaler_scale", "scaler_var"):
            _expect(arrays[key], (n,), key)
        if kind == "kernel_ridge_rbf":
            x_fit = _expect(arrays["x_fit"], (None, n), "x_fit")
            dual = _expect(arrays["dual_coef"], (x_fit.shape[0],), "dual_coef")
            return {"type": kind, "n": n, "x_fit": x_fit, "dual": dual, "alpha": _number(description, "alpha"),
                    "gamma": _number(description, "gamma")}
        if kind == "mlp_classifier":
            layers = int(description["layers"])
            if not 1 <= layers <= 16 or description.get("activation") not in ("logistic", "tanh", "relu", "identity") \
                    or description.get("out_activation") not in ("softmax", "logistic"):
                raise ValueError("unknown layers or activations")
            classes = arrays["classes"]
            if classes.dtype.kind != "U" or classes.ndim != 1 or len(classes) < 2:
                raise ValueError("classes must be a list of at least two names")
            coefs, intercepts, width = [], [], n
            for i in range(layers):
                w = _expect(arrays[f"coef_{i}"], (width, None), f"coef_{i}")
                coefs.append(w)
                intercepts.append(_expect(arrays[f"intercept_{i}"], (w.shape[1],), f"intercept_{i}"))
                width = w.shape[1]
            if width != (len(classes) if len(classes) > 2 else 1):
                raise ValueError(f"{width} outputs for {len(classes)} classes")
            return {"type": kind, "n": n, "layers": layers, "coefs": coefs, "intercepts": intercepts, "width": width,
                    "classes": classes, "activation": description["activation"],
                    "out_activation": description["out_activation"]}
        raise ValueError(f"unknown estimator type {kind!r}")
    except (KeyError, ValueError, TypeError) as exc:
        raise ModelError(f"{path}: not a usable model ({exc}); retrain it") from None


def _rebuild(parts: dict[str, Any], arrays: dict[str, np.ndarray]) -> Pipeline:
    """The scikit-learn pipeline of an estimator's checked parts (`_checked`)."""
    from sklearn.kernel_ridge import KernelRidge
    from sklearn.neural_network import MLPClassifier
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import LabelBinarizer

    n = parts["n"]
    model: KernelRidge | MLPClassifier
    if parts["type"] == "kernel_ridge_rbf":
        model = KernelRidge(alpha=parts["alpha"], kernel="rbf", gamma=parts["gamma"])
        model.X_fit_, model.dual_coef_, model.n_features_in_ = parts["x_fit"], parts["dual"], n
    else:
        model = MLPClassifier(activation=parts["activation"])
        model.coefs_, model.intercepts_ = parts["coefs"], parts["intercepts"]
        model.n_layers_, model.n_outputs_, model.out_activation_ = parts["layers"] + 1, parts["width"], \
            parts["out_activation"]
        model.classes_, model.n_features_in_ = parts["classes"], n
        model._label_binarizer = LabelBinarizer().fit(parts["classes"])
    return make_pipeline(_scaler(arrays, n), model)


def _expect(array: np.ndarray, shape: tuple[int | None, ...], name: str) -> np.ndarray:
    """`array` as finite float64 of `shape` (None: any length); ValueError otherwise."""
    if array.dtype.kind not in "fiu" or array.ndim != len(shape) or any(
            s is not None and s != a for s, a in zip(shape, array.shape)):
        raise ValueError(f"{name} has dtype {array.dtype} and shape {array.shape}, expected numbers of shape "
                         f"{tuple('n' if s is None else s for s in shape)}")
    array = array.astype(float)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} holds non-finite numbers")
    return array


def _number(description: dict, key: str) -> float:
    value = description[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
        raise ValueError(f"{key} must be a positive number, got {value!r}")
    return float(value)


def _plain(value: Any) -> Any:
    """JSON for the numpy scalars and arrays in a training report."""
    return value.tolist() if isinstance(value, (np.ndarray, np.generic)) else str(value)


@dataclass
class TrainedModel:
    kind: str
    estimator: Any
    info: dict  # training report, labels, data source

    def save(self, path: str | Path) -> Path:
        """Write the model as plain arrays and a JSON header (no pickle); returns the path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        description, arrays = export_estimator(self.estimator) if self.estimator is not None else (None, {})
        header = {"format": FORMAT, "version": VERSION, "kind": self.kind, "feature_spec": feature_spec(),
                  "estimator": description, "info": self.info}
        text = json.dumps(header, default=_plain, allow_nan=False)
        with open(path, "wb") as f:  # a file object: numpy would add .npz to a name without it
            np.savez_compressed(f, header=np.frombuffer(text.encode(), np.uint8), **arrays)
        return path


def _read(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    """Header and arrays of a model file, read without unpickling anything."""
    if not path.is_file():
        raise ModelError(f"{path}: not a regular file")
    if path.stat().st_size > MAX_BYTES:
        raise ModelError(f"{path}: larger than {MAX_BYTES >> 20} MiB")
    with open(path, "rb") as f:
        magic = f.read(2)
    if magic == b"PK":  # a zip: its arrays' sizes checked before any is inflated
        problem = npz_problem(path, MAX_BYTES)
        if problem:
            raise ModelError(f"{path}: not loaded: {problem}")
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
        header = json.loads(arrays.pop("header").tobytes().decode())
    except (ValueError, OSError, KeyError, EOFError, UnicodeDecodeError, zipfile.BadZipFile) as exc:
        pickled = path.read_bytes()[:2] == b"\x80\x04" or path.suffix == ".joblib"
        why = ("a pickle (joblib) file: pickles can run code when loaded and are refused"
               if pickled else f"not a model file ({type(exc).__name__}: {exc})")
        raise ModelError(f"{path}: {why}; retrain with `fvtree train` (models are .npz)") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ModelError(f"{path}: not an fvtree model file")
    return header, arrays


def _opened(path: str | Path, kind: str) -> tuple[dict, dict[str, np.ndarray], dict[str, Any]]:
    """(header, arrays, the estimator's checked parts) of a model file of `kind`; ModelError otherwise."""
    path = Path(path)
    if not path.exists():
        raise ModelError(f"no model file at {path}: train one with `fvtree train {kind} DATA --out {path}`")
    header, arrays = _read(path)
    if header.get("version") != VERSION:
        raise ModelError(f"{path}: model file version {header.get('version')}, expected {VERSION}; retrain it")
    if header.get("kind") != kind:
        raise ModelError(f"{path}: a {header.get('kind')!r} model, but a {kind!r} model is needed")
    try:
        check_spec(header.get("feature_spec", {}), f"model {path}")
    except ValueError as exc:
        raise ModelError(str(exc)) from None
    return header, arrays, _checked(header.get("estimator"), arrays, path)


def check_model_file(path: str | Path, kind: str) -> None:
    """Check a model file of `kind` as `load_model` does, without making its estimator (nor importing
    scikit-learn): what `fvtree validate` does with a tree's models; ModelError otherwise."""
    _opened(path, kind)


def load_model(path: str | Path, kind: str) -> TrainedModel:
    """Load a model of `kind`; ModelError with an actionable message otherwise."""
    header, arrays, parts = _opened(path, kind)
    info = header.get("info")
    return TrainedModel(kind, _rebuild(parts, arrays), info if isinstance(info, dict) else {})
