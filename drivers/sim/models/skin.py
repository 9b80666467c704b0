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

from dataclasses import replace

import numpy as np

from drivers.sim.models.fingervision_model import FingerContact
from perception.sensor_profile import SensorProfile

REST = 1e-9  # a felt load below this is none (so an unloaded skin hands on the shared rest contact)


class Skin:
    """One fingertip's skin: `feel(contact, now)` is the contact with the loads the markers show."""

    def __init__(self, profile: SensorProfile):
        self.lag, self.creep_time = profile.skin_lag_s, profile.skin_creep_s
        self.creep_share = profile.skin_creep_share if profile.skin_creep_s > 0.0 else 0.0
        self.hysteresis = profile.skin_hysteresis
        self.transparent = self.lag <= 0.0 and self.creep_share <= 0.0
        self._fast = np.zeros(4)
        self._slow = np.zeros(4)
        self._last: float | None = None

    def feel(self, contact: FingerContact, now: float) -> FingerContact:
        """The contact as the skin shows it at `now` (s on the cell clock)."""
        if self.transparent:
            return contact
        load = np.array([contact.normal, contact.shear[0], contact.shear[1], contact.torque], float)
        dt = 0.0 if self._last is None else max(now - self._last, 0.0)
        if self._last is None:
            self._fast[:] = self._slow[:] = 0.0 if self.lag > 0.0 else load
        self._last = now
        _relax(self._fast, load, dt, self.lag, self.hysteresis)
        _relax(self._slow, load, dt, self.creep_time, self.hysteresis)
        felt = (1.0 - self.creep_share) * self._fast + self.creep_share * self._slow
        felt[np.abs(felt) < REST] = 0.0
        if np.array_equal(felt, load):
            return contact
        return replace(contact, normal=float(felt[0]), shear=felt[1:3].copy(), torque=float(felt[3]))


def _relax(state: np.ndarray, load: np.ndarray, dt: float, tau: float, hysteresis: float) -> None:
    """Move `state` towards `load` over `dt` with time constant `tau` (slower by 1 + `hysteresis` on
    the channels unloading), in place; a zero time constant follows at once."""
    if tau <= 0.0:
        state[:] = load
        return
    unloading = np.abs(load) < np.abs(state)
    taus = np.where(unloading, tau * (1.0 + hysteresis), tau)
    state += (load - state) * (1.0 - np.exp(-dt / taus))
