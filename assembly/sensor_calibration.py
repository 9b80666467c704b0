"""`fvtree calibrate-sensor`: measure a FingerVision sensor's gains, rest noise and skin response
against known loads and write a sensor profile a cell file can name, as a lab would make one for its
own sensor.

On a cell with the press scene (a stick held between the fingertips above an electronic scale):

1. rest: the fingers open, nothing touching, for `rest_ticks`: the markers' median frame-to-frame
   step (`rest_jitter_px`) and the lag-1 autocorrelation of their positions (`jitter_persistence`);
2. response: the gripper closes on the stick at the largest grip force; the arm finds the scale,
   probes its stiffness under the stick, rests the stick on it at `base_n`, steps the load up by
   `step_n`, holds it `response_hold_s`, steps back down and holds again, as a lab presses and holds
   with the scale: the skin's lag, hysteresis and (if told apart from noise) creep are fitted to the
   markers' motion along the stick against the scale's reading, tick by tick
   (`assembly.skin_response`). Measured first, so that every gain step below is held until this skin
   shows it (`settle_lags` lags, `settle_creeps` creep times, at most `max_hold_s`; at least
   `hold_ticks`);
3. shear: still at that grip, the arm finds the scale again and presses the stick down in
   `press_steps` steps of `press_step_m`; each pad carries half the scale's reading along the stick:
   the markers' mean motion along it per newton (`shear_px_per_n`, the slope at zero load of a
   Hertz-Mindlin partial-slip curve through the steps: a grip nearing its friction capacity shears
   more per newton);
4. normal: lifted, the gripper holds the stick at set forces (`grip_forces`, N, from the largest
   down; the gripper's force set point is the known load, as a lab checks with a grip gauge): the
   markers' mean distance from rest per newton (`normal_px_per_n`, the slope of a line through the
   steps: a load the skin has not yet shown, alike at every step, falls into the intercept).

Every other number is kept from the cell's own profile with its source; the measured ones carry
"measured by calibrate_sensor on DATE" and how.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from assembly.skin_response import SkinFit, fit
from drivers.cell import Cell
from drivers.cell_builders import load_cell
from fvfiles.errors import FvtreeError
from perception.sensor_profile import SensorProfile, save_profile
from perception.state import FINGERS

TICK_HZ = 30.0


class CalibrationError(FvtreeError):
    """The calibration could not measure what it needs (no scale, the stick slipped, ...)."""


@dataclass(frozen=True)
class Plan:
    """The loads and durations of one calibration."""

    rest_ticks: int = 90
    grip_forces: tuple[float, ...] = (4.0, 8.0, 12.0, 16.0, 20.0)  # N, each pad
    hold_ticks: int = 60  # per step; the last half is averaged
    press_step_m: float = 0.0005  # the first step; the others shorter if the scale is stiff (max_press_n)
    press_steps: int = 6
    max_press_n: float = 14.0  # N on the scale at the last step at most (a stiff scale must not make the stick slip)
    find_speed: float = 0.005  # m/s down towards the scale
    touch_n: float = 0.3  # N on the scale: the stick has found it
    response: bool = True  # measure the skin's response (phase 4)
    base_n: float = 2.0  # N on the scale before and after the step (keeps the stick on it)
    step_n: float = 6.0  # N the load steps up by
    settle_s: float = 3.0  # s at the base load before the step
    response_hold_s: float = 8.0  # s the step is held, and then the base again
    step_speed: float = 0.05  # m/s of the arm's step (a few ticks)
    settle_lags: float = 5.0  # the gains' steps held at least this many measured (unloading) lags
    settle_creeps: float = 3.0  # and this many creep times, when a creep was told apart
    max_hold_s: float = 30.0  # but no longer than this


@dataclass
class Calibration:
    """What was measured, with the steps it was fitted on."""

    normal_px_per_n: float
    shear_px_per_n: float
    rest_jitter_px: float
    jitter_persistence: float
    normal_steps: list[tuple[float, float]]  # (N set, mean px from rest)
    shear_steps: list[tuple[float, float]]  # (N on the scale, mean px along the stick)
    skin: SkinFit | None = None  # the response fit (None: not measured)
    response: list[tuple[float, float]] | None = None  # (N on the scale, mean px along the stick) each tick
    hold_ticks: int = 60  # each gain step was held this long (longer for a slow skin)


class _Session:
    """The cell ticked by hand: sense, command, step; the marker fields of each tick kept."""

    def __init__(self, cell: Cell):
        self.cell = cell
        self.rest: dict[str, np.ndarray] = {}

    def ticks(self, n: int) -> list[tuple[Mapping[str, Any], dict]]:
        out: list[tuple[Mapping[str, Any], dict]] = []
        for _ in range(n):
            states = self.cell.sense()
            labels = self.cell.world.labels() if self.cell.world is not None else {}
            out.append((states, labels))
            self.cell.arm.kick()
            self.cell.step()
            fault = self.cell.arm.fault() or self.cell.gripper.fault()
            if fault:
                raise CalibrationError(f"the cell stopped during the calibration: {fault}")
        return out

    def moved(self, states: Mapping[str, Any], finger: str) -> tuple[np.ndarray, np.ndarray]:
        """Each marker's motion from its mean rest position, and which markers are tracked."""
        m = states[finger].markers
        return m.position - self.rest[finger], m.valid.astype(bool)


def calibrate(cell: Cell, plan: Plan = Plan()) -> Calibration:
    """Run the four phases on `cell` (its world must be the press scene, labelling `scale_force`)."""
    if cell.world is None or "scale_force" not in cell.world.labels():
        raise CalibrationError("calibrate_sensor needs a cell whose scene reads a scale (the press scene)")
    s = _Session(cell)
    jitter, persistence = _rest(s, s.ticks(plan.rest_ticks))
    cell.gripper.move(0.0, 0.05, max(plan.grip_forces))
    s.ticks(int(2.0 * TICK_HZ))  # the fingers close on the stick
    skin, response, hold = None, None, plan.hold_ticks
    if plan.response:  # first, so that the gains' steps are held until this skin has settled
        response = _respond(s, plan)
        loads, shown = np.array(response).T
        skin = fit(loads, shown, 1.0 / TICK_HZ)
        hold = max(hold, math.ceil(_settle_s(skin, plan) * TICK_HZ))
    shear_steps = _press(s, plan, hold)
    normal_steps = []
    for force in sorted(plan.grip_forces, reverse=True):  # down from the grip the stick is held with
        cell.gripper.move(0.0, 0.05, force)
        held = s.ticks(hold)[hold // 2:]
        normal_steps.append((force, _spread(s, [st for st, _ in held])))
    f, px = np.array(normal_steps).T
    normal = float(np.polyfit(f, px, 1)[0])
    shear = 2.0 * _mindlin_slope(*np.array(shear_steps).T)  # each pad carries half the scale's load
    if normal <= 0.0 or shear <= 0.0:
        raise CalibrationError(f"the markers did not move with the load (normal {normal:.4g}, shear {shear:.4g} px/N)")
    return Calibration(normal, shear, jitter, persistence, normal_steps, shear_steps, skin, response, hold)


def _settle_s(skin: SkinFit, plan: Plan) -> float:
    """How long a gain step must be held for `skin` to show most of it: `settle_lags` of its
    unloading lag, `settle_creeps` of its unloading creep time when a creep was told apart, at most
    `max_hold_s`."""
    slower = 1.0 + skin.hysteresis
    creep = plan.settle_creeps * skin.creep_s * slower if skin.creep_s is not None else 0.0
    return min(max(plan.settle_lags * skin.lag_s * slower, creep), plan.max_hold_s)


def _mindlin_slope(force: np.ndarray, px: np.ndarray) -> float:
    """px per newton at zero load of a gripped stick's shear: the steps fitted with a Hertz-Mindlin
    partial-slip curve, px = a + k 1.5 c (1 - (1 - F/c)^(2/3)) (the grip shears more per newton as
    the load nears its capacity c, which a line or a quadratic would fold into the slope)."""
    from scipy.optimize import curve_fit

    def curve(f, a, k, c):
        return a + k * 1.5 * c * (1.0 - np.clip(1.0 - f / c, 0.0, None) ** (2.0 / 3.0))

    line = np.polyfit(force, px, 1)
    try:
        (_, k, _), _ = curve_fit(curve, force, px, p0=(line[1], line[0], 4.0 * force.max()),
                                 bounds=([-np.inf, -np.inf, 1.05 * force.max()], [np.inf, np.inf, np.inf]))
    except (RuntimeError, ValueError):
        raise CalibrationError("the shear steps fit no partial-slip curve: press in more, smaller steps") from None
    return abs(float(k))


def _rest(s: _Session, ticks: list) -> tuple[float, float]:
    """Median frame-to-frame step of the tracked markers at rest, and the lag-1 autocorrelation of
    their positions; sets the rest positions the loaded steps are measured from."""
    steps, corr = [], []
    for finger in FINGERS:
        pos = np.array([st[finger].markers.position for st, _ in ticks])  # (T, N, 2)
        valid = np.array([st[finger].markers.valid for st, _ in ticks]).astype(bool)  # (T, N)
        s.rest[finger] = np.array([pos[valid[:, i], i].mean(axis=0) if valid[:, i].any() else pos[0, i]
                                   for i in range(pos.shape[1])])
        both = valid[1:] & valid[:-1]
        steps.append(np.linalg.norm(pos[1:] - pos[:-1], axis=2)[both])
        dev = pos - s.rest[finger]
        num = (dev[1:] * dev[:-1]).sum(axis=2)[both].sum()
        den = (dev[:-1] ** 2).sum(axis=2)[both].sum()
        corr.append(num / den if den > 0 else 0.0)
    return float(np.median(np.concatenate(steps))), float(max(0.0, min(np.mean(corr), 0.99)))


def _held_motion(s: _Session, held: list[Mapping[str, Any]], finger: str) -> np.ndarray:
    """(N, 2) each marker's mean motion from rest over the ticks it was tracked in `held` (markers
    never tracked left out): averaging per marker first keeps a marker the tracker drops now and then
    from changing which markers the mean is over."""
    moved = [s.moved(states, finger) for states in held]
    d = np.array([m for m, _ in moved])  # (T, N, 2)
    valid = np.array([v for _, v in moved])  # (T, N)
    seen = valid.sum(axis=0)
    total = (d * valid[:, :, None]).sum(axis=0)
    return total[seen > 0] / seen[seen > 0, None]


def _spread(s: _Session, held: list[Mapping[str, Any]]) -> float:
    """The markers' mean distance from rest over the held ticks, both fingers."""
    return float(np.mean([np.linalg.norm(_held_motion(s, held, f), axis=1).mean() for f in FINGERS]))


def _along(s: _Session, held: list[Mapping[str, Any]]) -> float:
    """The markers' mean motion along the stick (image y) over the held ticks, both fingers."""
    return float(np.mean([_held_motion(s, held, f)[:, 1].mean() for f in FINGERS]))


def _find_scale(s: _Session, plan: Plan) -> tuple[np.ndarray, float]:
    """Lift the held stick 3 mm, then lower it until the scale feels it: a reading beyond `touch_n` and
    beyond 5 standard deviations of the empty scale's readings (measured while lifted; a noisy scale
    passes 0.3 N now and then); the pose it started from and the scale's mean reading once touched."""
    arm = s.cell.arm
    start = arm.pose()
    arm.move_linear(start + np.array([0, 0, 0.003, 0, 0, 0]), 0.01)
    empty = [labels.get("scale_force", 0.0) for _, labels in s.ticks(30)[10:]]
    touch = max(plan.touch_n, float(np.mean(empty) + 5.0 * np.std(empty)))
    arm.speed_linear(np.array([0, 0, -plan.find_speed, 0, 0, 0]))
    for _ in range(int(0.1 / plan.find_speed * TICK_HZ)):  # at most 10 cm
        (_, labels), = s.ticks(1)
        if labels.get("scale_force", 0.0) > touch:
            break
    else:
        raise CalibrationError("the stick found no scale within 10 cm below it")
    arm.stop()
    touched = s.ticks(15)
    return start, float(np.mean([labels.get("scale_force", 0.0) for _, labels in touched]))


def _lift(s: _Session, start: np.ndarray) -> None:
    """Lift the stick off the scale to 3 mm above `start`; CalibrationError if it slid in the grip."""
    s.cell.arm.move_linear(start + np.array([0, 0, 0.003, 0, 0, 0]), 0.01)
    s.ticks(30)
    slid = s.cell.world.metrics().get("stick slid in the grip (mm)", 0.0) if s.cell.world is not None else 0.0
    if slid:
        raise CalibrationError(f"the stick slid {slid} mm in the grip while pressed: grip harder or press less")


def _press(s: _Session, plan: Plan, hold: int) -> list[tuple[float, float]]:
    """Lift the held stick, find the scale, press it in steps held `hold` ticks: (scale reading, motion
    along) per step. The steps after the first are shortened so that the last reads at most
    `max_press_n` (a stiff scale must not make the stick slip)."""
    arm = s.cell.arm
    start, touched = _find_scale(s, plan)
    steps, step = [], plan.press_step_m
    for i in range(plan.press_steps):
        arm.move_linear(arm.pose() - np.array([0, 0, step, 0, 0, 0]), 0.005)
        held = s.ticks(hold)[hold // 2:]
        steps.append((float(np.mean([lab["scale_force"] for _, lab in held])), _along(s, [st for st, _ in held])))
        if i == 0 and steps[0][0] > touched and plan.press_steps > 1:
            probe = (steps[0][0] - touched) / step  # N/m
            step = min(step, max(plan.max_press_n - steps[0][0], 0.0) / (probe * (plan.press_steps - 1)))
    _lift(s, start)
    if step <= 0.0:
        raise CalibrationError(f"the scale read {steps[0][0]:.2f} N at the first step, past max_press_n "
                               f"({plan.max_press_n:g} N): press in smaller steps")
    return steps


def _respond(s: _Session, plan: Plan) -> list[tuple[float, float]]:
    """Find the scale, probe its stiffness under the stick (one `press_step_m` step), rest the stick on
    it at the base load, step the load up, hold, step back, hold: the scale's reading and the markers'
    mean motion along the stick on every tick from a second before the step."""
    arm = s.cell.arm
    start, touched = _find_scale(s, plan)
    down = np.array([0, 0, 1.0, 0, 0, 0])
    arm.move_linear(arm.pose() - down * plan.press_step_m, 0.005)
    probed = float(np.mean([labels["scale_force"] for _, labels in s.ticks(int(TICK_HZ))[15:]]))
    stiffness = (probed - touched) / plan.press_step_m  # N/m
    if stiffness <= 0.0:
        raise CalibrationError(f"the scale read {touched:.2f} N touched and {probed:.2f} N pressed "
                               f"{plan.press_step_m * 1000:g} mm further: no more")
    arm.move_linear(arm.pose() - down * (plan.base_n - probed) / stiffness, plan.step_speed)
    s.ticks(int(plan.settle_s * TICK_HZ))
    base = arm.pose()
    record = s.ticks(int(TICK_HZ))
    arm.move_linear(base - down * plan.step_n / stiffness, plan.step_speed)
    record += s.ticks(int(plan.response_hold_s * TICK_HZ))
    arm.move_linear(base, plan.step_speed)
    record += s.ticks(int(plan.response_hold_s * TICK_HZ))
    _lift(s, start)
    along = np.mean([_along_each_tick(s, [st for st, _ in record], f) for f in FINGERS], axis=0)
    return [(float(lab["scale_force"]), float(px)) for (_, lab), px in zip(record, along)]


def _along_each_tick(s: _Session, states: list[Mapping[str, Any]], finger: str) -> np.ndarray:
    """(T,) the markers' mean motion along the stick (image y) on each tick, over the markers tracked on
    at least 90 % of the ticks, a marker's dropped ticks filled with its last (or first) tracked value:
    a marker the tracker drops for a tick must not step the mean."""
    moved = [s.moved(st, finger) for st in states]
    along = np.array([m[:, 1] for m, _ in moved])  # (T, N)
    valid = np.array([v for _, v in moved])  # (T, N)
    keep = valid.mean(axis=0) >= 0.9
    if not keep.any():
        raise CalibrationError(f"the {finger} tracker kept no marker through the response")
    along, valid = along[:, keep], valid[:, keep]
    for i in range(along.shape[1]):
        seen = np.flatnonzero(valid[:, i])
        last = np.maximum.accumulate(np.where(valid[:, i], np.arange(len(valid)), -1))
        along[:, i] = along[np.where(last >= 0, last, seen[0]), i]
    return along.mean(axis=1)


def profile_of(cal: Calibration, base: SensorProfile, name: str, where: str,
               today: datetime.date | None = None) -> SensorProfile:
    """`base` with the measured numbers in, each with its source."""
    date = (today or datetime.date.today()).isoformat()
    how = f"measured by calibrate_sensor on {date} ({where})"
    n_steps = ", ".join(f"{f:g} N: {px:.3f} px" for f, px in cal.normal_steps)
    s_steps = ", ".join(f"{f:.2f} N: {px:.3f} px" for f, px in cal.shear_steps)
    sources = {**base.sources,
               "normal_px_per_n": f"{how}: markers' mean distance from rest against the grip force set point, "
                                  f"slope of a line through {n_steps}",
               "shear_px_per_n": f"{how}: markers' mean motion along the stick against the scale reading (half "
                                 f"on each pad), slope at zero load of a Hertz-Mindlin partial-slip curve through {s_steps}",
               "rest_jitter_px": f"{how}: median frame-to-frame step of the tracked markers, fingers open",
               "jitter_persistence": f"{how}: lag-1 autocorrelation of the markers' rest positions"}
    skin = _skin_numbers(cal, how) if cal.skin is not None else {}
    sources.update({key: source for key, (_, source) in skin.items()})
    if cal.skin is not None and not cal.skin.creep_told_apart:
        for key in ("skin_creep_share", "skin_creep_s"):
            sources[key] = (f"{base.sources.get(key, 'the base profile').rstrip('.')}; kept: calibrate_sensor on "
                            f"{date} told no creep apart from the markers' noise (a lag alone fitted the response)")
    fitted: dict[str, Any] = {key: value for key, (value, _) in skin.items()}
    return replace(base, name=name, normal_px_per_n=round(cal.normal_px_per_n, 4),
                   shear_px_per_n=round(cal.shear_px_per_n, 4), rest_jitter_px=round(cal.rest_jitter_px, 4),
                   jitter_persistence=round(cal.jitter_persistence, 3), **fitted, sources=sources)


def _skin_numbers(cal: Calibration, how: str) -> dict[str, tuple[float, str]]:
    """The skin's fitted numbers for the profile, {field: (value, source)}; the creep only when told
    apart from noise (else the base profile's creep and its source stay)."""
    skin = cal.skin
    assert skin is not None and cal.response is not None
    loads = [f for f, _ in cal.response]
    step = (f"{how}: the scale stepped from {np.percentile(loads, 5):.1f} to {np.percentile(loads, 95):.1f} N and "
            f"back, each held, {skin.samples} ticks of the markers' mean motion along the stick against the "
            f"scale's reading fitted with the skin model (residual {skin.residual_px:.4f} px rms")
    frame = 1.0 / TICK_HZ
    unresolved = f"; below one frame ({frame:.3f} s) a lag is not told from none" if skin.lag_s < frame else ""
    out = {"skin_lag_s": (round(skin.lag_s, 4), f"{step}): fast time constant{unresolved}"),
           "skin_hysteresis": (round(skin.hysteresis, 3), f"{step}): unloading against loading time constants")}
    if skin.creep_share is not None and skin.creep_s is not None:
        creep = f"{step}, {skin.lag_only_residual_px:.4f} px without creep)"
        out["skin_creep_share"] = (round(skin.creep_share, 4), f"{creep}: share shown only after creep")
        out["skin_creep_s"] = (round(skin.creep_s, 3), f"{creep}: creep time constant")
    return out


def run(out: str | Path, cell: str = "sim", seed: int = 0, perception: str | None = None,
        scene_args: dict | None = None, plan: Plan = Plan()) -> tuple[Path, Calibration]:
    """Calibrate the sensor of `cell` (the press scene) and write its profile to `out`."""
    the_cell = load_cell(cell, TICK_HZ, "press", scene_args or {}, seed=seed, perception=perception)
    try:
        cal = calibrate(the_cell, plan)
    finally:
        the_cell.close()
    where = f"cell {cell}, seed {seed}" + (f", {perception}" if perception else "")
    profile = profile_of(cal, the_cell.sensor_profile, Path(out).stem, where)
    return save_profile(profile, out), cal
