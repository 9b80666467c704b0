"""Viscoelastic FingerVision skin: the load the markers show lags the load on the fingertip.

Silicone answers a step load with a fast part that follows in `lag` seconds and a slow creep over
`creep_time` seconds (a `creep_share` of the load), and unloads more slowly than it loads
(`hysteresis`: the unloading time constants are (1 + hysteresis) times the loading ones). Two
first-order branches per load channel (normal, shear x and y, torque), as a standard linear solid:

    fast += (L - fast) (1 - exp(-dt / tau)),  tau = lag, or lag (1 + hysteresis) while |L| falls below |fast|
    slow += (L - slow) (1 - exp(-dt / tau_c)), likewise with creep_time
    felt = (1 - creep_share) fast + creep_share slow

Defaults and ranges live in the sensor profile (`skin_lag_s`, `skin_creep_share`, `skin_creep_s`,
`skin_hysteresis`); no FingerVision time constant is published, silicone skins sit at 0.1-2 s. With
a zero lag and no creep the skin is transparent (the contact is handed on unchanged).
"""

from __future__ import annotations

import numpy as np

from drivers.sim.models.fingervision_model import FingerContact
from perception.sensor_profile import SensorProfile

REST = 1e-9  # a felt load below this is none (so an unloaded skin hands on the shared rest contact)
CHANNELS = 4  # normal, shear x, shear y, torque


class Skin:
    """One fingertip's skin: `feel(contact, now)` is the contact with the loads the markers show.

    It runs once per finger per tick on four numbers, so it works on Python floats (numpy's cost per
    call is many times the arithmetic on four numbers), with the same operations in the same order as
    the array form in the module docstring, so the results are the same bit for bit."""

    def __init__(self, profile: SensorProfile):
        self.lag, self.creep_time = profile.skin_lag_s, profile.skin_creep_s
        self.creep_share = profile.skin_creep_share if profile.skin_creep_s > 0.0 else 0.0
        self.hysteresis = profile.skin_hysteresis
        self.transparent = self.lag <= 0.0 and self.creep_share <= 0.0
        self._fast = [0.0] * CHANNELS
        self._slow = [0.0] * CHANNELS
        self._last: float | None = None
        self._steps: dict[float, tuple[float, float, float, float]] = {}  # dt -> `_step_shares(dt)`

    def feel(self, contact: FingerContact, now: float) -> FingerContact:
        """The contact as the skin shows it at `now` (s on the cell clock)."""
        if self.transparent:
            return contact
        shear_x, shear_y = contact.shear.tolist()
        load = [float(contact.normal), shear_x, shear_y, float(contact.torque)]
        dt = 0.0 if self._last is None else max(now - self._last, 0.0)
        if self._last is None:
            self._fast = [0.0] * CHANNELS if self.lag > 0.0 else list(load)
            self._slow = list(self._fast)
        self._last = now
        fast_load, fast_unload, slow_load, slow_unload = self._step_shares(dt)
        self._fast = fast = _relax(self._fast, load, self.lag, fast_load, fast_unload)
        self._slow = slow = _relax(self._slow, load, self.creep_time, slow_load, slow_unload)
        keep, creep = 1.0 - self.creep_share, self.creep_share
        # The four channels written out: a list comprehension a channel list costs a call each.
        f0, f1, f2, f3 = (keep * fast[0] + creep * slow[0], keep * fast[1] + creep * slow[1],
                          keep * fast[2] + creep * slow[2], keep * fast[3] + creep * slow[3])
        felt = [0.0 if abs(f0) < REST else f0, 0.0 if abs(f1) < REST else f1,
                0.0 if abs(f2) < REST else f2, 0.0 if abs(f3) < REST else f3]
        if felt == load:
            return contact
        return FingerContact(felt[0], np.array(felt[1:3]), felt[3], contact.centre, contact.obj, contact.slip)

    def _step_shares(self, dt: float) -> tuple[float, float, float, float]:
        """The share of the way to the load each branch goes in `dt` (1 - exp(-dt / tau)): fast loading,
        fast unloading, slow loading, slow unloading. Worked out once per `dt` (a cell clock's ticks
        give a handful of values, its period with different rounding), with numpy's exp as an array,
        as the array form does."""
        shares = self._steps.get(dt)
        if shares is None:
            taus = np.array([self.lag, self.lag * (1.0 + self.hysteresis),
                             self.creep_time, self.creep_time * (1.0 + self.hysteresis)])
            with np.errstate(divide="ignore", invalid="ignore"):  # a zero time constant: see _relax
                shares = tuple((1.0 - np.exp(-dt / taus)).tolist())
            if len(self._steps) > 64:  # a clock whose steps keep changing (none here): do not grow
                self._steps.clear()
            self._steps[dt] = shares
        return shares


def _relax(state: list[float], load: list[float], tau: float, loading: float, unloading: float) -> list[float]:
    """`state` moved towards `load` by the share `loading` of the way, or `unloading` on the channels
    whose load falls below the state (slower by 1 + hysteresis); a zero time constant follows at once."""
    if tau <= 0.0:
        return list(load)
    s0, s1, s2, s3 = state
    x0, x1, x2, x3 = load
    return [s0 + (x0 - s0) * (unloading if abs(x0) < abs(s0) else loading),
            s1 + (x1 - s1) * (unloading if abs(x1) < abs(s1) else loading),
            s2 + (x2 - s2) * (unloading if abs(x2) < abs(s2) else loading),
            s3 + (x3 - s3) * (unloading if abs(x3) < abs(s3) else loading)]
