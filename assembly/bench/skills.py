"""`fvtree bench skills`: the tactile skill library measured on the simulated cell.

1. FollowMe, ForceTrack+SpeedCtrl against ObjectTrack, pull and push along each tool axis:
   tracking error and command jerk (vision is blind along the fingers' closing axis, y).
2. In-hand rotation, torque- against slip-driven, on a heavy bar and a light pen.
3. ForceLearn: test error against the number of training presses; and trained on some objects
   (wood, rubber, steel), tested on held-out presses of those and on objects it never saw (glass,
   foam), beside the thesis's MSE on a real sensor.
4. StirLearn: the paper's MLP against the obvious alternatives, each trained on sessions of the
   randomised cell (each session its own sensor gain, rest jitter, skin lag, batch of substances)
   and tested on held-out trials of those sessions and on every trial of held-out sessions, beside
   the paper's f1 on a real sensor; and the demo model's own held-out figures, from its report.
Writes skills.csv (benchmark, case, metric, value), skills.md and skills.png.
"""

from __future__ import annotations

import csv
import tempfile
from pathlib import Path

import numpy as np

from assembly.bench.robustness import randomised_cell
from assembly.dataset_recorder import record, record_run
from assembly.language.reader import load_tree
from assembly.run.options import RunOptions
from assembly.run.session import Run, world_of
from perception.learning.dataset import Dataset

TREES = Path(__file__).resolve().parents[2] / "trees"


def run_tree_text(text: str, scene_args: dict, seed: int = 0) -> tuple[str, dict]:
    """Run a tree given as YAML text on the simulated cell with these scene args; (status, scene
    metrics)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "tree.yaml"
        path.write_text(text)
        doc = load_tree(path)
    options = RunOptions(seed=seed, scene_args=scene_args, max_time=600.0, runs_dir=None, record=False,
                         plots=False, quiet=True, supervised=False)
    with Run(doc, options) as run:
        result = run.loop()
    return result.status, world_of(run.cell).metrics()


def followme(rows: list) -> None:
    for skill in ("force_track", "object_track"):
        text = (TREES / f"{skill}.yaml").read_text()
        for axis in "xyz":
            for direction in ("pull", "push"):
                status, m = run_tree_text(text, {"axis": axis, "direction": direction})
                case = f"{skill} {axis} {direction}"
                rows += [("followme", case, "status", status),
                         ("followme", case, "tracking error rms (mm)", m["tracking error rms (mm)"]),
                         ("followme", case, "tracking error final (mm)", m["tracking error final (mm)"]),
                         ("followme", case, "command jerk rms (m/s^3)", m["command jerk rms (m/s^3)"])]


def inhand(rows: list) -> None:
    base = (TREES / "in_hand_rot.yaml").read_text()
    for scene, squeeze in (("inhand", 0.005), ("inhand_light", 0.001)):
        for variant in ("torque", "slip"):
            text = (base.replace("scene: inhand", f"scene: {scene}").replace("variant: slip", f"variant: {variant}")
                    .replace("name: grasp}", f"name: grasp, params: {{squeeze: {squeeze}}}}}"))
            status, m = run_tree_text(text, {})
            case = f"{variant} {'heavy bar' if scene == 'inhand' else 'light pen'}"
            rows += [("in_hand_rot", case, "status", status),
                     ("in_hand_rot", case, "turned (deg, target 60)", m["turned in the hand (deg)"]),
                     ("in_hand_rot", case, "dropped", m["stick dropped"])]


def forcelearn(rows: list, work: Path, quick: bool) -> None:
    from perception.learning.force import fit_force, marker_columns, press_ids, split_presses

    rec = Dataset.load(record(TREES / "record_press.yaml", work / "press.npz"))
    x, y, truth = rec.features[:, marker_columns()], rec.label("scale_force").astype(float), rec.labels["true_force"]
    presses = press_ids(rec)
    train, test = split_presses(presses)
    train_presses = np.unique(presses[train])
    for n in ((2, 6, 15) if quick else (2, 4, 6, 10, 15)):
        use = train & np.isin(presses, train_presses[:n])
        model, _ = fit_force(x[use], y[use], presses[use], max_samples=300 if quick else 600)
        predicted = model.predict(x[test])
        rows += [("forcelearn", f"{n} presses", "rmse vs scale (N)", round(float(np.sqrt(np.mean((predicted - y[test]) ** 2))), 4)),
                 ("forcelearn", f"{n} presses", "rmse vs true force (N)", round(float(np.sqrt(np.mean((predicted - truth[test]) ** 2))), 4))]
    rows.append(("forcelearn", "scale", "noise std (N)", rec.header["label_info"]["scale_force"]["noise_std"]))


SEEN_OBJECTS, UNSEEN_OBJECTS = ("wood", "rubber", "steel"), ("glass", "foam")
THESIS_MSE = 1.23  # N^2, ForceLearn on a real FingerVision (the thesis, via the seed paper)


def forcelearn_objects(rows: list, quick: bool) -> None:
    """ForceLearn trained on presses of some objects and tested on held-out presses of those (seen)
    and on every press of others (unseen), as the paper warns the mapping is object-dependent:
    RMSE and MSE against the scale, beside the thesis's MSE on a real sensor."""
    from perception.learning.force import fit_force, marker_columns, press_ids, split_presses

    seen, unseen = (SEEN_OBJECTS[:1], UNSEEN_OBJECTS[:1]) if quick else (SEEN_OBJECTS, UNSEEN_OBJECTS)
    data = {}
    for obj in seen + unseen:
        rec = record_run(TREES / "record_press.yaml", cell="sim_calibration", scene_args={"object": obj})
        data[obj] = (rec.features[:, marker_columns()], rec.label("scale_force").astype(float), press_ids(rec))
    parts = []
    for i, obj in enumerate(seen):
        x, y, presses = data[obj]
        train, test = split_presses(presses)
        parts.append((x[train], y[train], presses[train] + 1000 * i, x[test], y[test]))
    model, _ = fit_force(np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                         np.concatenate([p[2] for p in parts]), max_samples=300 if quick else 900)
    cases = [(f"seen: {', '.join(seen)} (held-out presses)", np.concatenate([p[3] for p in parts]),
              np.concatenate([p[4] for p in parts]))]
    cases += [(f"unseen: {obj}", data[obj][0], data[obj][1]) for obj in unseen]
    for case, x, y in cases:
        mse = float(np.mean((model.predict(x) - y) ** 2))
        rows += [("forcelearn objects", case, "rmse vs scale (N)", round(mse**0.5, 3)),
                 ("forcelearn objects", case, "mse (N^2)", round(mse, 3)),
                 ("forcelearn objects", case, "thesis mse, real sensor (N^2)", THESIS_MSE)]


SAME_SESSION, OTHER_SESSION = "f1, held-out trials of the sessions", "f1, held-out sessions"
PAPER_F1 = "paper f1, real sensor (one session)"
PAPER_STIR_F1 = 0.98  # the paper's MLP 3x10 on held-out trials of its one recorded session
STIR_TRAIN_SEEDS, STIR_TEST_SEEDS = 100, 200  # first seeds of the training and of the held-out sessions
DEMO_MODEL = TREES / "models" / "stir_sim.npz"


def stirlearn(rows: list, work: Path, quick: bool) -> None:
    """Every classifier trained on randomised sessions (`record_stir_randomised.yaml`, seeds from
    100) and tested on held-out trials of them and on held-out sessions (seeds from 200): another
    sensor, skin and batch, as a lab meets them. Then the demo model's figures from its report."""
    import json

    from sklearn.metrics import f1_score

    from perception.learning.stir import classifiers, split, trials

    tree = work / "record_stir_randomised.yaml"
    tree.write_text((TREES / "record_stir_randomised.yaml").read_text().replace("times: 8", f"times: {4 if quick else 8}"))
    cell = randomised_cell(work)
    sessions = (2, 1) if quick else (12, 6)
    (x, y), (x_other, y_other) = (
        trials(Dataset.load(record(tree, work / f"stir{first}.npz", cell=str(cell), seed=first, runs=n)))
        for first, n in zip((STIR_TRAIN_SEEDS, STIR_TEST_SEEDS), sessions))
    train, test = split(y)
    for (name, model), whole in zip(classifiers(trials=len(train)).items(), classifiers(trials=len(y)).values()):
        same = f1_score(y[test], model.fit(x[train], y[train]).predict(x[test]), average="macro")
        other = f1_score(y_other, whole.fit(x, y).predict(x_other), average="macro")
        rows += [("stirlearn", name, SAME_SESSION, round(float(same), 4)),
                 ("stirlearn", name, OTHER_SESSION, round(float(other), 4)),
                 ("stirlearn", name, PAPER_F1, PAPER_STIR_F1)]
    report = json.loads(DEMO_MODEL.with_suffix(".report.json").read_text())
    demo = f"demo model {DEMO_MODEL.name} ({report['train_trials']} trials)"
    rows += [("stirlearn", demo, OTHER_SESSION, round(report["models"][report["saved"]]["f1"], 4)),
             ("stirlearn", demo, PAPER_F1, PAPER_STIR_F1)]


def _values(rows, bench, metric) -> dict:
    return {case: value for b, case, m, value in rows if b == bench and m == metric}


def plot(rows: list, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(13, 8))
    err, jerk = _values(rows, "followme", "tracking error rms (mm)"), _values(rows, "followme", "command jerk rms (m/s^3)")
    cases = [f"{a} {d}" for a in "xyz" for d in ("pull", "push")]
    width = 0.4
    ax = axes[0, 0]
    for i, skill in enumerate(("force_track", "object_track")):
        ax.bar(np.arange(6) + (i - 0.5) * width, [err[f"{skill} {c}"] for c in cases], width, label=skill)
    ax.set(xticks=range(6), xticklabels=cases, ylabel="tracking error rms [mm]", yscale="log",
           title="FollowMe: tracking error (y = closing axis, vision blind)")
    twin = ax.twinx()
    twin.plot(np.arange(6) - width / 2, [jerk[f"force_track {c}"] for c in cases], "o", color="C0")
    twin.plot(np.arange(6) + width / 2, [jerk[f"object_track {c}"] for c in cases], "o", color="C1")
    twin.set_ylabel("command jerk rms [m/s^3] (dots)")
    ax.legend(loc="upper left")
    turned = _values(rows, "in_hand_rot", "turned (deg, target 60)")
    status = _values(rows, "in_hand_rot", "status")
    ax = axes[0, 1]
    names = list(turned)
    ax.bar(names, [turned[n] for n in names], color=["C2" if status[n] == "SUCCESS" else "C3" for n in names])
    ax.axhline(60, color="0.4", ls="--", lw=1)
    ax.set(ylabel="turned in the hand [deg]", title="InHandRot: green reached the 60 deg target, red failed")
    ax = axes[1, 0]
    vs_true, vs_scale = _values(rows, "forcelearn", "rmse vs true force (N)"), _values(rows, "forcelearn", "rmse vs scale (N)")
    n = [int(k.split()[0]) for k in vs_true]
    ax.plot(n, list(vs_true.values()), "o-", label="against the true force")
    ax.plot(n, list(vs_scale.values()), "s-", label="against the scale reading")
    noise = _values(rows, "forcelearn", "noise std (N)")["scale"]
    ax.axhline(noise, color="0.4", ls="--", lw=1, label="scale noise std")
    ax.set(xlabel="training presses", ylabel="test RMSE [N]", yscale="log", title="ForceLearn")
    ax.legend()
    ax = axes[1, 1]
    same, other = _values(rows, "stirlearn", SAME_SESSION), _values(rows, "stirlearn", OTHER_SESSION)
    names = list(same)
    ax.barh(np.arange(len(names)) + width / 2, [same[n] for n in names], width, label="held-out trials of the sessions")
    ax.barh(np.arange(len(names)) - width / 2, [other[n] for n in names], width, label="held-out sessions")
    ax.axvline(PAPER_STIR_F1, color="0.4", ls="--", lw=1, label=f"paper (real sensor) {PAPER_STIR_F1}")
    for i, n in enumerate(names):
        ax.text(other[n], i - width / 2, f" {other[n]:.2f}", va="center", fontsize=8)
    ax.set(yticks=range(len(names)), yticklabels=names, xlim=(0, 1.1), xlabel="macro f1",
           title="StirLearn on the randomised cell: the paper's MLP 3x10 and the alternatives")
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def markdown(rows: list) -> str:
    lines = ["# Tactile skill benchmarks (simulated cell)", ""]
    for bench in dict.fromkeys(b for b, *_ in rows):
        metrics = list(dict.fromkeys(m for b, _, m, _ in rows if b == bench))
        cases = list(dict.fromkeys(c for b, c, _, _ in rows if b == bench))
        table = {(c, m): v for b, c, m, v in rows if b == bench}
        lines += [f"## {bench}", "", "| case | " + " | ".join(metrics) + " |", "|---" * (len(metrics) + 1) + "|"]
        lines += [f"| {c} | " + " | ".join(str(table.get((c, m), "")) for m in metrics) + " |" for c in cases]
        lines.append("")
    return "\n".join(lines)


def run(out_dir: Path, quick: bool = False) -> list[Path]:
    """Run every benchmark; write the CSV, Markdown and PNG into `out_dir`."""
    rows: list[tuple] = []
    followme(rows)
    inhand(rows)
    with tempfile.TemporaryDirectory() as tmp:
        forcelearn(rows, Path(tmp), quick)
        forcelearn_objects(rows, quick)
        stirlearn(rows, Path(tmp), quick)
    table = out_dir / "skills.csv"
    with open(table, "w", newline="") as f:
        csv.writer(f).writerows([("benchmark", "case", "metric", "value"), *rows])
    md = out_dir / "skills.md"
    md.write_text(markdown(rows))
    return [table, md, plot(rows, out_dir / "skills.png")]
