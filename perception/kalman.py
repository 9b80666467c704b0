"""The thesis Kalman filter on every marker at once (Sadybakasov 2019, sec. 2.2.4).

State per marker [x0, xt, y0, yt, s] with
  A = [[1, dt, 0, 0, 0], [0, 1, 0, 0, 0], [0, 0, 1, dt, 0], [0, 0, 0, 1, 0], [0, 0, 0, 0, 1]],
  H = rows (x0, y0, s), Q = q I, R = r I, initial covariance c I, dt = 1 / camera fps:
a constant-velocity filter on the position and a random walk on the size. The covariance update
is the standard (I - K H) P (the thesis' eq. 2.4 prints (I - Q H)^-1, a typo).

Because A is block diagonal and Q, R, P0 are multiples of I, the x and y blocks share one 2x2
covariance per marker and the size one scalar, so the filter is exact with per-marker arrays of
three plus one numbers. Markers without a measurement keep their estimate (no extrapolation) while
their covariance grows. Optional: an innovation gate (chi-square, 2 dof) that restarts a marker at
its measurement, so a real step is followed at once instead of being smoothed away; and a motion
gate on each marker's neighbourhood (given as neighbour indices), so that smooth motion, too small
per marker to pass the innovation gate, is followed instead of lagged.
"""

from __future__ import annotations

import numpy as np

from perception.config import KalmanConfig
from perception.tracking_kernels import kalman_step, moving_hoods


class MarkerKalman:
    """Per-marker Kalman filter on all markers at once (its step compiled); `update` filters one frame
    of measurements."""

    def __init__(self, cfg: KalmanConfig, dt: float, position: np.ndarray, size: np.ndarray,
                 neighbours: np.ndarray | None = None):
        if dt <= 0:
            raise ValueError(f"Kalman time step must be positive, got {dt}")
        self.cfg, self.dt = cfg, float(dt)
        self._neighbours(neighbours)
        n = len(size)
        self.pos = np.asarray(position, float).copy()  # (N, 2)  x0, y0
        self.vel = np.zeros((n, 2))  # (N, 2)  xt, yt
        self.size = np.asarray(size, float).copy()  # (N,)
        self.p00 = np.full(n, cfg.initial_cov)  # position variance
        self.p01 = np.zeros(n)  # position-velocity covariance
        self.p11 = np.full(n, cfg.initial_cov)  # velocity variance
        self.ps = np.full(n, cfg.initial_cov)  # size variance

    def _neighbours(self, neighbours: np.ndarray | None) -> None:
        """The motion test's neighbourhoods: each marker's neighbour indices (N, k), besides itself."""
        self._hood = None if neighbours is None else np.ascontiguousarray(neighbours, np.int64)

    def add(self, position: np.ndarray, size: np.ndarray, neighbours: np.ndarray | None = None) -> None:
        """Append markers at rest at `position` (K, 2) with `size` (K,); `neighbours`: the new (N + K)
        markers' neighbour indices. Existing markers keep their indices and estimates."""
        k, c = len(size), self.cfg.initial_cov
        self.pos = np.concatenate([self.pos, position])
        self.vel = np.concatenate([self.vel, np.zeros((k, 2))])
        self.size = np.concatenate([self.size, size])
        self.p00, self.p11, self.ps = (np.concatenate([p, np.full(k, c)]) for p in (self.p00, self.p11, self.ps))
        self.p01 = np.concatenate([self.p01, np.zeros(k)])
        self._neighbours(neighbours)

    def restart(self, which: np.ndarray, position: np.ndarray, size: np.ndarray) -> None:
        """Re-initialise the selected markers at the given position and size, at rest."""
        if not which.any():  # the usual frame: nothing to do (and selecting none costs ~10 us)
            return
        c = self.cfg.initial_cov
        self.pos[which] = position[which]
        self.size[which] = size[which]
        self.vel[which] = 0.0
        self.p00[which], self.p01[which], self.p11[which], self.ps[which] = c, 0.0, c, c

    def update(self, z_pos: np.ndarray, z_size: np.ndarray, valid: np.ndarray):
        """Filter one frame: (N, 2) positions and (N,) sizes, used where `valid`; returns (pos, size).
        The predict-correct step is compiled (`tracking_kernels.kalman_step`); then markers whose
        innovation, or whose neighbourhood's, is too large for noise restart at their measurement."""
        nu, s = kalman_step(self.pos, self.vel, self.size, self.p00, self.p01, self.p11, self.ps,
                            np.asarray(z_pos, float), np.asarray(z_size, float), np.asarray(valid, bool),
                            float(self.cfg.process_noise), float(self.cfg.measurement_noise), self.dt)
        jump = np.zeros(len(valid), bool)
        if self.cfg.reinit_gate > 0:
            jump = valid & ((nu * nu).sum(axis=1) / s > self.cfg.reinit_gate)
        if self.cfg.motion_gate > 0 and self._hood is not None:
            jump |= self._moving(nu, valid)
        if jump.any():
            self.restart(jump, z_pos, z_size)
        return self.pos.copy(), self.size.copy()

    def _moving(self, nu: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """(N,) markers whose neighbourhood (itself and its neighbours) moves: the mean innovation over
        its m markers is too large for noise (m |mean|^2 / sigma^2 above `motion_gate`, chi-square with
        2 dof). sigma is measured on this frame: the spread of each marker's innovation about its
        neighbourhood's mean (robust median). A smooth motion of the skin shows in the mean long before
        one marker's innovation leaves its noise, so these markers follow their measurement at once.
        `nu`: (N, 2) innovations, 0 where not `valid` (compiled: `tracking_kernels.moving_hoods`)."""
        return moving_hoods(nu, np.asarray(valid, bool), self._hood, float(self.cfg.motion_gate))
