"""PressWithForce (ForceLearn): press the held object along the tool z axis until the force a
learned model predicts from the marker field reaches a target in newtons, and hold there.

What a real cell gives the skill is measured on the spot, not read from constants:

- **The skin's lag.** A viscoelastic skin shows a load up to a second late (silicone: 0.1-2 s), so a
  press that trusts the markers while it moves overshoots (1 s of lag: 31 N for a 5 N target). The
  skill first stands still where the contact search stopped until the learned force is steady (two
  `window`s agree within `steady`, or within the reading's own noise), and takes the skin's time
  constant from that settling (the time the reading needs to cover 63 % of its change); the press
  then undoes it (force = shown + lag x d(shown)/dt over the last LAG_WINDOW_S).
- **The sensor's gain.** A skin's marker motion per newton is never exactly the profile's (gel
  thickness, camera distance: +-30 %), nor is the grip the model was trained on. At every stand the
  learned force is scaled to the arm's own TCP force along the press (`k` = TCP / learned, both
  settled). The TCP force is read against its rest level before contact, which
  `descend_until_contact` measures (`/task/force_zero`, the mean of its reference ticks after zeroing
  a cell that can, as ur_rtde's zeroFtSensor): a UR reads several newtons of offset, and a zeroing
  folds one noisy reading into it. Without that key the reading is taken as zeroed.
- **Whether the target was reached** is judged standing still on the TCP force averaged over a
  `window` (no lag, its noise averaged), within the tolerance or twice the mean's measured noise. A
  stand short of or past the target is corrected by a position step (the least-squares slope of
  the stands' force against depth: the contact's stiffness, measured; a small probe step while they
  are too close together to show it), up to `max_steps` times.

docs/robustness.md has the figures on the randomised cell."""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, time_limit
from behaviours.skill_kit.control import MovingAverage
from behaviours.skill_kit.geometry import rotation
from behaviours.skill_kit.model_files import UsesModel
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.sensor import sensor_profile
from perception.learning.features import tick_features

LAG_WINDOW_S = 0.3  # s of shown force whose slope undoes the skin's lag
MAX_STEP = 0.003  # m, the largest correcting step between two stands
MIN_SPREAD = 0.0002  # m of depth between stands below which their forces show noise, not stiffness
PROBE_STEP = 0.0003  # m towards the target when the stands show no stiffness yet


@register
class PressWithForce(UsesModel, ProgramSkill):
    NAME = "press_with_force"
    MODEL_KIND = "force"
    SUMMARY = "press along tool z until the learned force (ForceLearn) reaches a target in newtons"
    PARAMS = {
        "model": Param("str", "ForceLearn model file (fvtree train force)", "trees/models/force_sim.npz"),
        "target": Param("float", "force to press with", 5.0, "N", min=0.0),
        "tolerance": Param("float", "how close to the target counts as reached (or twice the measured noise of "
                           "the averaged TCP force, if larger)", 0.3, "N", min=0.01),
        "gain": Param("float", "press speed per newton of force error", 0.002, "m/s/N", min=0.0),
        "max_speed": Param("float", "press speed limit", 0.005, "m/s", min=1e-4, max=0.05, device="arm_speed"),
        "settle": Param("int", "ticks the learned force must stay within the tolerance before standing", 10, min=1),
        "window": Param("float", "standing still: s over which a reading is averaged and judged steady", 1.0, "s",
                        min=0.05),
        "steady": Param("float", "standing still: the learned force is steady once two windows agree this well "
                        "(or within their noise)", 0.05, "N", min=0.0),
        "max_steps": Param("int", "correcting steps (stand, step by the measured stiffness) before giving up", 8,
                           min=1),
        "max_travel": Param("float", "give up after pressing this far", 0.1, "m", min=0.0, max=1.0),
        "max_force": Param("float", "abort above this force", 20.0, "N", min=0.0),
        "smoothing": Param("int", "ticks in the moving average of the predicted force", 3, min=1),
        "max_time": time_limit(60.0, "give up when the force has not settled within this time"),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING, keys.ROBOT_WRENCH,
             keys.FORCE_ZERO)
    OPTIONAL_READS = (keys.FORCE_ZERO,)
    NEEDS = ("surface",)
    WRITES = (keys.PRESS_FORCE,)

    def program(self):
        from perception.learning.force import predict_force  # scikit-learn: loaded by a run, not by `fvtree validate`

        if self.model is None:
            return self.fail(self.model_error)
        model, arm = self.model, self.cell.arm
        start = self.pose()
        self._start, self._t0 = start, self.now()
        axis = rotation(start)[:, 2]
        average = MovingAverage(self.p.smoothing)
        window = max(3, round(self.p.window / self.cell.clock.period))
        zero = np.asarray(self.read(keys.FORCE_ZERO, [0.0, 0.0, 0.0]), dtype=float)

        def read() -> tuple[float, float]:
            """(learned force, the arm's TCP force along the press) this tick, N."""
            shown = float(average.update(predict_force(model, tick_features(*self.tactile()))))
            return shown, -float((np.asarray(self.read(keys.ROBOT_WRENCH)[:3], dtype=float) - zero) @ axis)

        def depth() -> float:
            return float((self.pose()[:3] - start[:3]) @ axis)

        # 1. stand where the contact search stopped: the skin's response and the first calibration
        arm.stop()
        stand = yield from self._stand(read, window, learned=True)
        if isinstance(stand, str):
            return self.fail(stand)
        lag = stand.lag if stand.lag is not None else sensor_profile(self.cell).skin_lag_s
        scale = stand.calibration(1.0)
        stands = [(depth(), stand.felt)]
        # 2. press by the learned force, its lag undone and scaled to the arm's force, until it shows the target
        if not self._reached(stand):
            why = yield from self._approach(read, scale, lag)
            if why:
                return self.fail(why)
        # 3. stand, and correct by the contact's measured stiffness until the TCP force is at the target
        for _ in range(self.p.max_steps):
            stand = yield from self._stand(read, window, learned=False)
            if isinstance(stand, str):
                return self.fail(stand)
            stands.append((depth(), stand.felt))
            if self._reached(stand):
                self.write(keys.PRESS_FORCE, stand.felt)
                self.feedback_message = (f"pressing with {stand.felt:.2f} N (target {self.p.target:.2f} N; skin lag "
                                         f"{lag:.2f} s, learned force x{scale:.2f})")
                return Status.SUCCESS
            if stand.felt < 0.5 and scale * stand.shown > 0.5 * self.p.target:
                return self.fail(f"the learned force reads {scale * stand.shown:.2f} N but the arm's force sensor "
                                 f"feels {stand.felt:.2f} N: it does not read the press, so the target cannot be "
                                 "judged (is the sensor zeroed, or blind along the press?)")
            step = correction(stands, self.p.target)
            if step is None:  # too close together to show the stiffness: a small step the way the force must go
                step = PROBE_STEP if stand.felt < self.p.target else -PROBE_STEP
            pose = self.pose().copy()
            pose[:3] += axis * step
            why = yield from self.move(pose, self.p.max_speed, watch=lambda: self._trouble(read()[1]))
            if why:
                return self.fail(why)
        return self.fail(f"the force did not settle within {self.p.tolerance} N of {self.p.target} N in "
                         f"{self.p.max_steps} steps (now {stands[-1][1]:.2f} N by the arm's force sensor, "
                         f"{stands[-1][0] * 1000:.1f} mm pressed): is the force sensor reading the press?")

    def _reached(self, stand: Stand) -> bool:
        return abs(stand.felt - self.p.target) <= max(self.p.tolerance, 2.0 * stand.felt_noise)

    def _trouble(self, felt: float, learned: float = 0.0) -> str | None:
        """Why the press must stop now (None: it may go on); the force is the larger of the arm's and
        the learned one as the model reads it."""
        force = max(felt, learned)
        travelled = float(np.linalg.norm(self.pose()[:3] - self._start[:3]))
        if force > self.p.max_force:
            self.cell.arm.stop()
            return f"pressing with {force:.1f} N, above max_force {self.p.max_force} N: lower the gain or the speed"
        if travelled > self.p.max_travel:
            self.cell.arm.stop()
            return (f"pressed {travelled * 1000:.0f} mm and feel only {force:.2f} N: nothing under the object, or the "
                    "model does not fit this object")
        held = self.held_at_box()
        if held:
            self.cell.arm.stop()
            return (f"pressed {travelled * 1000:.0f} mm to the workspace box's {held} and feel only {force:.2f} N: "
                    "the safety layer stops the arm there")
        if self.now() - self._t0 > self.p.max_time:
            self.cell.arm.stop()
            return (f"the force did not settle within {self.p.tolerance} N of the target in {self.p.max_time:.0f} s "
                    f"(now {force:.2f} N): lower the gain, or raise 'smoothing' against a noisy prediction")
        fault = self.arm_fault()
        return f"arm fault: {fault}" if fault else None

    def _stand(self, read: Callable[[], tuple[float, float]], window: int, learned: bool):
        """Steps (`yield from`) standing still: returns a `Stand` once the TCP force has been averaged over
        `window` ticks (and, if `learned`, the learned force is steady too), or why the press must stop."""
        shown: list[float] = []
        felt: list[float] = []
        while True:
            yield
            s, f = read()
            shown.append(s)
            felt.append(f)
            why = self._trouble(f)
            if why:
                return why
            if len(felt) < window or (learned and not steady(shown, window, self.p.steady)):
                continue
            return Stand.of(shown, felt, window, self.cell.clock.period)

    def _approach(self, read: Callable[[], tuple[float, float]], scale: float, lag: float):
        """Steps (`yield from`) pressing at a speed proportional to the error of the learned force (lag
        undone, scaled), until it has stayed within the tolerance for `settle` ticks or the arm's force
        has passed the target the way the press goes (pressing on past it, or easing off below it); None,
        or why the press must stop."""
        arm, period = self.cell.arm, self.cell.clock.period
        history: deque = deque(maxlen=max(3, round(LAG_WINDOW_S / period)))
        felt_recent: deque = deque(maxlen=max(3, self.p.smoothing))
        axis, within = rotation(self._start)[:, 2], 0
        while within < self.p.settle:
            shown, felt = read()
            history.append((self.now(), shown))
            felt_recent.append(felt)
            force = scale * (shown + lag * slope(history))
            why = self._trouble(felt, shown)  # not the lag-undone force: its slope spikes on a noisy tick
            if why:
                return why
            error = self.p.target - force
            within = within + 1 if abs(error) <= self.p.tolerance else 0
            speed = float(np.clip(self.p.gain * error, -self.p.max_speed, self.p.max_speed))
            if len(felt_recent) == felt_recent.maxlen and np.sign(speed) * (np.mean(felt_recent) - self.p.target) > self.p.tolerance:
                break  # the arm feels the target passed the way the press goes: stand and correct from there
            arm.speed_linear(np.r_[axis * speed, 0.0, 0.0, 0.0])
            self.feedback_message = f"pressing with {force:.2f} N of {self.p.target:.2f} N (learned, lag {lag:.2f} s)"
            yield
        arm.stop()
        return None


@dataclass(frozen=True)
class Stand:
    """What one stand measured: the mean learned and TCP force over its last window, the TCP mean's
    noise, and the skin's time constant seen in the learned force's settling (None: too small a change)."""

    shown: float
    felt: float
    felt_noise: float
    lag: float | None

    @classmethod
    def of(cls, shown: list[float], felt: list[float], window: int, period: float) -> Stand:
        last = np.array(felt[-window:])
        final = float(np.mean(shown[-window:]))
        noise = float(np.std(shown[-window:]))
        return cls(final, float(last.mean()), float(last.std() / math.sqrt(window)),
                   time_constant(shown, final, noise, period))

    def calibration(self, fallback: float) -> float:
        """The learned force's scale to the arm's force (`fallback` when either is too small to tell)."""
        if self.shown < 1.0 or self.felt < 1.0:
            return fallback
        return float(np.clip(self.felt / self.shown, 0.25, 4.0))


def steady(values: list[float], window: int, eps: float) -> bool:
    """Whether the last `window` values' mean agrees with the `window` before's within `eps` or
    within their noise (three standard errors of the difference)."""
    if len(values) < 2 * window:
        return False
    new, old = np.array(values[-window:]), np.array(values[-2 * window:-window])
    noise = 3.0 * math.sqrt((new.var() + old.var()) / window)
    return abs(float(new.mean() - old.mean())) <= max(eps, noise)


def time_constant(values: list[float], final: float, noise: float, period: float) -> float | None:
    """Seconds a reading standing still took to cover 63 % (1 - 1/e) of its way from the first value to
    `final`: a first-order response's time constant; None when the change is within 4 x `noise`."""
    change = final - values[0]
    if abs(change) <= 4.0 * noise or abs(change) < 1e-9:
        return None
    for i, value in enumerate(values):
        if (final - value) / change <= math.exp(-1.0):
            return i * period
    return len(values) * period


def correction(stands: list[tuple[float, float]], target: float) -> float | None:
    """The step (m along the press) from the last stand to the target force, by the stiffness the
    stands show (the least-squares slope of force against depth over the stands that felt force, at
    least MIN_SPREAD apart in depth; None when they show no stiffness), at most MAX_STEP."""
    force = stands[-1][1]
    loaded = np.array([s for s in stands if s[1] > 0.5])
    if len(loaded) < 2 or np.ptp(loaded[:, 0]) < MIN_SPREAD:
        return None
    d, f = loaded[:, 0] - loaded[:, 0].mean(), loaded[:, 1]
    stiffness = float(d @ (f - f.mean()) / (d @ d))
    if stiffness <= 0.0:
        return None
    return float(np.clip((target - force) / stiffness, -MAX_STEP, MAX_STEP))


def slope(history: deque) -> float:
    """Rate of change (per s) of the (time, value) pairs: the slope of a least-squares line."""
    if len(history) < 3:
        return 0.0
    t, v = np.array(history).T
    t = t - t.mean()
    denominator = float(t @ t)
    return float(t @ (v - v.mean()) / denominator) if denominator > 0.0 else 0.0
