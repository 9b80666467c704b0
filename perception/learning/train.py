"""`fvtree train force|stir DATA --out MODEL`: train on a recording, print the paper's kind of
report, and save the model (`.npz`, plain arrays) with its report (JSON) and chart (PNG) next to it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from perception.learning.dataset import Dataset
from perception.learning.models import SUFFIX, ModelError


def format_force_report(report: dict) -> str:
    noise = report.get("scale_noise_std")
    lines = [(f"ForceLearn (kernel ridge, RBF; alpha {report['hyper_parameters']['alpha']}, "
              f"gamma {report['hyper_parameters']['gamma']} by grouped CV)"),
             (f"  presses {report['presses']}: {report['train_ticks']} training ticks, "
              f"{report['test_ticks']} test ticks (every 4th press held out)"),
             f"  MSE {report['mse']:.4f} N^2   RMSE {report['rmse']:.3f} N   R2 {report['r2']:.4f}  (against the scale)"]
    if "rmse_vs_true_force" in report:
        lines.append(f"  RMSE against the true force {report['rmse_vs_true_force']:.3f} N"
                     + (f" (scale noise std {noise} N)" if noise is not None else ""))
    lines.append("  per held-out press or trial:")
    lines += [f"    {g['group']:4d}: mean load {g['mean_load']:8.3f} N  MSE {g['mse']:.4f} N^2"
              + (f"  R2 {g['r2']:.3f}" if g["r2"] is not None else "") for g in report["held_out_groups"]]
    return "\n".join(lines)


def format_stir_report(report: dict) -> str:
    lines = [(f"StirLearn: {report['train_trials']} training / {report['test_trials']} test trials, "
              f"tested on {report['tested_on']}")]
    for name, result in report["models"].items():
        marker = " (saved)" if name == report["saved"] else ""
        lines.append(f"\n{name}{marker}: f1 {result['f1']:.3f}\n{result['table']}")
    return "\n".join(lines)


def plot_force(report: dict, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    measured, predicted = np.array(report["test"]["measured"]), np.array(report["test"]["predicted"])
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    a.plot(measured, predicted, ".", ms=3)
    top = max(measured.max(), predicted.max())
    a.plot([0, top], [0, top], color="0.5", lw=1)
    a.set(xlabel="measured by the scale [N]", ylabel="predicted from the markers [N]",
          title=f"ForceLearn test: RMSE {report['rmse']:.3f} N, R2 {report['r2']:.3f}")
    b.plot(measured, color="0.6", label="scale")
    b.plot(predicted, color="C0", lw=1, label="predicted")
    b.set(xlabel="test tick", ylabel="force [N]", title="held-out presses")
    b.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def run(kind: str, data: list[str | Path], out: str | Path, seed: int = 0, test: str | Path | None = None) -> list[Path]:
    """Train a `kind` model on the recordings `data` (joined; StirLearn: tested on the recording
    `test` of another session when given), save it at `out`; returns the files written."""
    out = Path(out)
    if out.suffix != SUFFIX:
        raise ModelError(f"a model file is {SUFFIX} (plain arrays, no pickle), got {out.name}", str(out))
    parts = [Dataset.load(path) for path in data]
    for path, part in zip(data, parts):
        if part.header.get("columns") != parts[0].header.get("columns"):
            raise ModelError(f"its feature columns differ from those of {data[0]}: record both with this version",
                             str(path))
    rec = parts[0] if len(parts) == 1 else Dataset.concatenate(parts, {
        **parts[0].header, "source": {"recordings": [p.header.get("source", {}) for p in parts]}})
    out.parent.mkdir(parents=True, exist_ok=True)
    if kind == "force":
        from perception.learning.force import train_force

        model, report = train_force(rec, seed=seed)
        print(format_force_report(report))
        chart = plot_force(report, out.with_suffix(".png"))
    elif kind == "stir":
        from perception.learning.stir import plot_stir, train_stir

        model, report = train_stir(rec, seed=seed, test_session=Dataset.load(test) if test else None)
        print(format_stir_report(report))
        chart = plot_stir(report, out.with_suffix(".png"))
    else:
        raise ValueError(f"unknown model kind {kind!r}; expected force or stir")
    written = [model.save(out), chart]
    summary = out.with_suffix(".report.json")
    summary.write_text(json.dumps({k: v for k, v in report.items() if k != "test"}, indent=1) + "\n")
    return written + [summary]
