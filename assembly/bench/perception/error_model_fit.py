"""`python -m assembly.bench.perception.error_model_fit`: what the real FingerVision pipeline gets wrong in
pixel mode, measured against the scene's truth, and the compact error model fitted to it that
signals mode applies (`drivers/sim/models/pipeline_error_model.py`).

Demo trees run in pixel mode (`recording.record`); every tick compares the pipeline's state with
the truth it was rendered from (the lag-1 correlations and `lossy_hold` are reported beside the
fitted model, which draws its errors afresh every tick: signals mode does not carry them yet):
- markers: position noise on still ticks (std of the error after removing each marker's bias)
  and its lag-1 correlation, the first-order lag a of the marker filter (y += a (truth - y),
  fitted on the whole run), the share of markers not tracked, and how it concentrates: the share
  of markers lost on more than 10 % of ticks, how often those are lost and how often one lost is
  still lost on the next tick;
- object: misses and false detections, area as a share of the true area and its noise, centroid
  and angle noise, and the lag-1 correlation of the area's noise;
- slip: the pipeline's slip against the image motion the scene causes (object texture sliding,
  the object moving or turning in the image, the markers moving), fitted as
  slip = gain * area * min(motion, saturation), the rest as a noise floor; the delay of the
  first tick over half the fitted value after a true slip starts, and the lag-1 correlation of
  the slip's relative noise.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np

from assembly.bench import script
from assembly.bench.perception import report
from assembly.bench.perception.pixel_runs import PixelRun, Tick, first_element_only, record
from drivers.sim.models.pipeline_error_model import IMAGE_SCALE, PipelineErrors, image_motion
from perception.state import FINGERS

TREES = Path(__file__).resolve().parents[3] / "trees"
RUNS = ("hold.yaml", "in_hand_rot.yaml", "object_track.yaml", "assembly.yaml")
QUICK_RUNS = ("hold.yaml", "in_hand_rot.yaml")


def _series(ticks: list[Tick]):
    truth = np.stack([t.position for t in ticks])  # (T, N, 2)
    pipe = np.stack([t.state.markers.position for t in ticks])
    valid = np.stack([t.state.markers.valid for t in ticks])
    return truth, pipe, valid


def marker_errors(ticks: list[Tick]) -> dict:
    """Noise on still ticks and its lag-1 correlation, lag of the filter, markers lost and how long."""
    truth, pipe, valid = _series(ticks)
    moved = np.abs(np.diff(truth, axis=0)).max(axis=(1, 2))
    still = np.r_[False, moved < 1e-3]
    still &= np.r_[False, still[:-1]]  # still for two ticks: the filter has settled
    err = pipe - truth
    noise, corr = 0.0, 0.0
    if still.sum() > 5:
        e = err[still]
        e = e - e.mean(axis=0, keepdims=True)
        ok = valid[still]
        noise = float(np.sqrt((e[ok] ** 2).mean()))
        pairs = (still[1:] & still[:-1])[np.flatnonzero(still)[1:] - 1]  # consecutive still ticks
        both = ok[1:] & ok[:-1] & pairs[:, None]
        if both.sum() > 5:
            corr = float((e[1:] * e[:-1])[both].sum() / np.sqrt((e[1:][both] ** 2).sum() * (e[:-1][both] ** 2).sum()))
    best = (np.inf, 1.0)
    for a in np.linspace(0.1, 1.0, 19):
        y = truth[0].copy()
        sq = 0.0
        for t in range(1, len(truth)):
            y += a * (truth[t] - y)
            sq += float(((pipe[t] - y)[valid[t]] ** 2).sum())
        best = min(best, (sq, float(a)))
    loss = 1.0 - valid.mean(axis=0)  # per marker
    lossy = loss > 0.1
    lost = ~valid[:, lossy]
    held = float((lost[1:] & lost[:-1]).sum() / lost[:-1].sum()) if lost[:-1].any() else 0.0
    return {"noise_px": noise, "noise_corr": corr, "lag_alpha": best[1], "dropout": float(loss.mean()),
            "lossy_share": float(lossy.mean()), "lossy_rate": float(loss[lossy].mean()) if lossy.any() else 0.0,
            "lossy_hold": held}


def object_errors(ticks: list[Tick]) -> dict:
    """Misses, false detections, area scale and noise, centroid and angle noise."""
    present = np.array([t.contact.obj.present and t.contact.obj.area > 0 for t in ticks])
    seen = np.array([t.state.obj.present for t in ticks])
    both = present & seen
    out = {"miss": float((~seen[present]).mean()) if present.any() else 0.0,
           "false": float(seen[~present].mean()) if (~present).any() else 0.0}
    if both.sum() < 5:
        return {**out, "area_scale": 1.0, "area_noise": 0.0, "centroid_px": 0.0, "angle_rad": 0.0,
                "object_corr": 0.0}
    area = np.array([(t.contact.obj.area, t.state.obj.area) for t, b in zip(ticks, both) if b])
    scale = float(np.median(area[:, 1] / area[:, 0]))
    residual = area[:, 1] - scale * area[:, 0]
    cen = np.array([(t.state.obj.centroid - t.contact.obj.centroid) for t, b in zip(ticks, both) if b]) * IMAGE_SCALE
    ang = np.array([t.state.obj.orientation - t.contact.obj.orientation for t, b in zip(ticks, both) if b])
    ang = (ang + np.pi / 2) % np.pi - np.pi / 2  # an axis: modulo pi
    return {**out, "area_scale": scale, "area_noise": float(np.std(area[:, 1] - scale * area[:, 0])),
            "centroid_px": float(np.sqrt(((cen - cen.mean(axis=0)) ** 2).sum(axis=1).mean())),
            "angle_rad": float(np.std(ang)), "object_corr": lag1(residual, both)}


def lag1(x: np.ndarray, kept: np.ndarray) -> float:
    """Lag-1 correlation of `x` (mean removed), the values of the ticks `kept` marks, over the
    pairs of them on neighbouring ticks."""
    x = x - x.mean()
    neighbours = kept[np.flatnonzero(kept)[1:] - 1]
    a, b = x[:-1][neighbours], x[1:][neighbours]
    return float((a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum())) if a.size > 5 and a.any() else 0.0


def slip_samples(ticks: list[Tick]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per tick: (object area, image motion px/frame, true slip, the pipeline's slip)."""
    area, motion, truth, pipe = [], [], [], []
    for prev, tick in itertools.pairwise(ticks):
        area.append(tick.contact.obj.area if tick.contact.obj.present else 0.0)
        motion.append(image_motion(prev.contact, tick.contact, prev.position, tick.position))
        truth.append(tick.contact.slip)
        pipe.append(tick.state.slip)
    return np.array(area), np.array(motion), np.array(truth), np.array(pipe)


def fit_slip(area: np.ndarray, motion: np.ndarray, pipe: np.ndarray) -> tuple[float, float, float]:
    """(gain, saturation px/frame, noise floor) of slip = gain * area * min(motion, saturation)."""
    best = (np.inf, 0.0, 1.0)
    for sat in (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0):
        x = area * np.minimum(motion, sat)
        gain = float(max((x @ pipe) / max(x @ x, 1e-12), 0.0))
        sq = float(((pipe - gain * x) ** 2).sum())
        best = min(best, (sq, gain, sat))
    _, gain, sat = best
    floor = float(np.median(pipe[motion < 1e-3])) if (motion < 1e-3).any() else 0.0
    return gain, sat, floor


def relative_noise(pipe: np.ndarray, expected: np.ndarray) -> float:
    """Robust std (1.4826 MAD) of the pipeline's slip relative to the model's, where it expects slip."""
    on = expected > 0.01
    if not on.any():
        return 0.0
    ratio = pipe[on] / expected[on] - 1.0
    return float(1.4826 * np.median(np.abs(ratio - np.median(ratio))))


def slip_delay(truth: np.ndarray, pipe: np.ndarray, expected: np.ndarray) -> tuple[float, int, int]:
    """(median delay in ticks, onsets, missed onsets): from a true slip's start to the first tick
    the pipeline shows over half of what the model expects, within 10 ticks."""
    onsets = np.flatnonzero((truth[1:] > 0.01) & (truth[:-1] <= 0.01)) + 1
    delays, missed = [], 0
    for i in onsets:
        hit = np.flatnonzero(pipe[i:i + 10] > 0.5 * max(expected[i], 1e-3))
        if hit.size:
            delays.append(int(hit[0]))
        else:
            missed += 1
    return (float(np.median(delays)) if delays else 0.0), len(onsets), missed


def measure(runs: list[PixelRun]) -> tuple[list[dict], PipelineErrors]:
    """Per-run error table and the error model fitted to all runs together."""
    rows, pooled = [], []
    markers, objects = [], []
    for rec in runs:
        for finger in FINGERS:
            ticks = rec.ticks[finger]
            m, o = marker_errors(ticks), object_errors(ticks)
            markers.append(m)
            objects.append(o)
            pooled.append(slip_samples(ticks))
            rows.append({"run": rec.tree, "finger": finger, "status": rec.status, "ticks": len(ticks), **m, **o})
    area, motion, truth, pipe = (np.concatenate(x) for x in zip(*pooled))
    gain, sat, floor = fit_slip(area, motion, pipe)
    expected = gain * area * np.minimum(motion, sat)
    delay, onsets, missed = slip_delay(truth, pipe, expected)
    on = expected > 0.01
    still = motion < 1e-3
    model = PipelineErrors(
        noise_px=float(np.median([m["noise_px"] for m in markers])),
        lag_alpha=float(np.median([m["lag_alpha"] for m in markers])),
        lossy_share=float(np.mean([m["lossy_share"] for m in markers])),
        lossy_rate=float(np.mean([m["lossy_rate"] for m in markers if m["lossy_share"]] or [0.0])),
        object_miss=float(np.mean([o["miss"] for o in objects])),
        area_scale=float(np.median([o["area_scale"] for o in objects])),
        area_noise=float(np.median([o["area_noise"] for o in objects])),
        centroid_px=float(np.median([o["centroid_px"] for o in objects])),
        angle_rad=float(np.median([o["angle_rad"] for o in objects])),
        slip_gain=gain, slip_saturation=sat, slip_floor=floor,
        slip_noise=relative_noise(pipe, expected),
        slip_delay=round(delay))
    rows.append({"run": "all (fitted model)", "finger": "both", "status": "", "ticks": len(pipe),
                 "noise_px": model.noise_px, "noise_corr": float(np.median([m["noise_corr"] for m in markers])),
                 "lag_alpha": model.lag_alpha,
                 "dropout": float(np.mean([m["dropout"] for m in markers])), "lossy_share": model.lossy_share,
                 "lossy_rate": model.lossy_rate,
                 "lossy_hold": float(np.mean([m["lossy_hold"] for m in markers if m["lossy_share"]] or [0.0])),
                 "miss": model.object_miss, "false": float(np.mean([o["false"] for o in objects])),
                 "area_scale": model.area_scale, "area_noise": model.area_noise,
                 "centroid_px": model.centroid_px, "angle_rad": model.angle_rad,
                 "object_corr": float(np.median([o["object_corr"] for o in objects]))})
    slip_row = {"slip gain": gain, "saturation px/frame": sat, "floor (still)": floor,
                "noise std": model.slip_noise, "noise lag-1 corr": lag1(pipe[on] / expected[on] - 1.0, on),
                "delay ticks": delay, "true onsets": onsets, "missed": missed,
                "still p95": float(np.percentile(pipe[still], 95)) if still.any() else 0.0,
                "moving p95": float(np.percentile(pipe[~still], 95)) if (~still).any() else 0.0}
    return rows + [slip_row], model


def run(out_dir: Path, quick: bool = False) -> list[Path]:
    """Record the demo runs in pixel mode, write errors.md/csv and the fitted model (JSON)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    runs = []
    for name in QUICK_RUNS if quick else RUNS:
        tree = TREES / name
        if "for_each_element" in tree.read_text():
            tree = first_element_only(tree, out_dir)
        runs.append(record(tree, max_time=20.0 if quick else 120.0))
    rows, model = measure(runs)
    written = report.write_table(out_dir, "errors", rows[:-1], "Pipeline errors in pixel mode against the truth")
    written += report.write_table(out_dir, "slip_errors", rows[-1:], "Slip against the image motion")
    model_path = out_dir / "pipeline_errors.json"
    model_path.write_text(json.dumps(model.as_dict(), indent=2) + "\n")
    return [*written, model_path]


if __name__ == "__main__":
    raise SystemExit(script("python -m assembly.bench.perception.error_model_fit", run, "bench/perception_errors",
                            "two short runs (smoke test)", __doc__))
