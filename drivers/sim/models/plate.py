"""Bendable plate as a simply supported beam strip (Euler-Bernoulli, closed form).

Uniform load w plus a point load P at c moves the deflection peak off-centre. A vertical element
at a (b = L - a from the right support) whose top leaves clearance g0 under the unloaded plate
carries the force R that makes the deflections compatible: the plate comes down y_load(a) under
its loads and goes back up R a^2 b^2 / (3 E I L) under R, while the element, grip and gel pads
(series stiffness k) give R / k, so y_load(a) - R a^2 b^2 / (3 E I L) = g0 + R / k, and

    R(a) = max(0, y_load(a) - g0) / (a^2 b^2 / (3 E I L) + 1/k)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BeamPlate:
    span: float = 1.0  # L, m
    EI: float = 50.0  # bending stiffness, N m^2
    w: float = 100.0  # uniform load, N/m
    P: float = 40.0  # point load, N
    c: float = 0.7  # point-load position from the left support, m
    k: float = 2000.0  # series stiffness of element + grip + gel, N/m

    def _unit_point(self, x: np.ndarray, a: float | np.ndarray) -> np.ndarray:
        """Deflection at x under a unit load at a (Maxwell-symmetric influence function)."""
        L = self.span
        lo, hi = np.minimum(x, a), np.maximum(x, a)
        b = L - hi
        return b * lo * (L**2 - b**2 - lo**2) / (6.0 * self.EI * L)

    def deflection(self, x) -> np.ndarray:
        """Downward deflection of the unpropped plate at x (m)."""
        x = np.clip(np.asarray(x, dtype=float), 0.0, self.span)
        L = self.span
        y_w = self.w * x * (L**3 - 2 * L * x**2 + x**3) / (24.0 * self.EI)
        return y_w + self.P * self._unit_point(x, self.c)

    def weight(self) -> float:
        """Total load on the plate (N): an element pushing up harder lifts it off its supports."""
        return self.w * self.span + self.P

    def self_flexibility(self, a) -> np.ndarray:
        a = np.asarray(a, dtype=float)
        b = self.span - a
        return a**2 * b**2 / (3.0 * self.EI * self.span)

    def carried_force(self, a, clearance) -> np.ndarray | float:
        """R(a): load an element at a with unloaded clearance g0 = `clearance` carries (N); a float
        for float arguments (the simulated cell asks this for one element a few times a tick)."""
        if isinstance(a, float) and isinstance(clearance, float):
            return self._carried_force_at(a, clearance)
        a = np.clip(np.asarray(a, dtype=float), 0.0, self.span)
        gap = self.deflection(a) - clearance
        return np.maximum(0.0, gap) / (self.self_flexibility(a) + 1.0 / self.k)

    def _carried_force_at(self, a: float, clearance: float) -> float:
        """`carried_force` of one position on Python floats, bit for bit: the array path works on
        numpy scalars (whose ** is libm's pow, as Python's is) except `a**2` in `self_flexibility`, a
        0-d array that numpy squares (x * x); the same operations in the same order, without numpy's
        per-call cost."""
        L, EI = self.span, self.EI
        x = a if math.isnan(a) else min(max(a, 0.0), L)  # as np.clip: a NaN stays NaN
        lo, hi = min(x, self.c), max(x, self.c)
        b = L - hi
        y = (self.w * x * (L**3 - 2 * L * x**2 + x**3) / (24.0 * EI)
             + self.P * (b * lo * (L**2 - b**2 - lo**2) / (6.0 * EI * L)))
        b = L - x
        return max(0.0, y - clearance) / ((x * x) * b**2 / (3.0 * EI * L) + 1.0 / self.k)

    def max_load(self, clearance: float, lo: float = 0.0, hi: float | None = None):
        """(a*, R(a*)): the true maximum-load position within [lo, hi] (dense search + refine)."""
        hi = self.span if hi is None else hi
        xs = np.linspace(lo, hi, 2001)
        i = int(np.argmax(self.carried_force(xs, clearance)))
        fine = np.linspace(xs[max(i - 1, 0)], xs[min(i + 1, len(xs) - 1)], 401)
        r = self.carried_force(fine, clearance)
        j = int(np.argmax(r))
        return float(fine[j]), float(r[j])
