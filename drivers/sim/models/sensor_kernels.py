"""The compiled kernels of the signals-mode FingerVision sensor: the marker field under a contact's
loads (`fingervision_model`) and one tick of the pipeline's errors (`pipeline_error_model`). In a
module of their own so that numba loads with the first sensor made, not with every import of the
scenes (`fvtree validate` reads the scene table)."""

from __future__ import annotations

import numpy as np
from numba import njit

from perception.sums import pairwise_sum
from perception.wrench_kernel import mean_wrench


@njit(cache=True, nogil=True)
def marker_field(rest, basis, shear_x, shear_y, spread, turn, growth):  # pragma: no cover - compiled
    """(N, 3) x, y, size of the markers: `rest` (3N,) moved by the loads through `basis` (5, 3N)."""
    loads = np.array([shear_x, shear_y, spread, turn, growth])
    return (rest + np.dot(loads, basis)).reshape(-1, 3)


@njit(cache=True, nogil=True, error_model="numpy")
def observe(exact, prev, estimate, tracked, noise, alpha, origin, terms):  # pragma: no cover - compiled
    """One tick of the marker errors, in one pass: the tracker's `estimate` (N, 3, updated in place)
    follows `exact` with the first-order lag `alpha` where `tracked`; returns the reported ((N, 2)
    positions, (N,) sizes) with `noise` (N, 3) added, the mean |motion| of the exact positions since
    `prev` (summed in numpy's pairwise order, as `image_motion` sums them), and the (force, torque)
    the wrench estimator makes of the tracked markers (`origin`, `terms`: `perception.wrench`)."""
    n = len(exact)
    position = np.empty((n, 2))
    size = np.empty(n)
    for i in range(n):
        if tracked[i]:
            for j in range(3):
                estimate[i, j] = exact[i, j] if alpha >= 1.0 else estimate[i, j] + alpha * (exact[i, j] - estimate[i, j])
        position[i, 0] = estimate[i, 0] + noise[i, 0]
        position[i, 1] = estimate[i, 1] + noise[i, 1]
        size[i] = estimate[i, 2] + noise[i, 2]
    moved = np.empty(2 * n)
    for i in range(n):
        moved[2 * i] = abs(exact[i, 0] - prev[i, 0])
        moved[2 * i + 1] = abs(exact[i, 1] - prev[i, 1])
    force, torque = mean_wrench(position, origin, terms, tracked)
    return position, size, pairwise_sum(moved, 0, 2 * n) / (2 * n), force, torque
