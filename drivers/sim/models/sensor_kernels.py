"""The compiled kernels of the signals-mode FingerVision sensor: the marker field under a contact's
loads (`fingervision_model`) and one tick of the pipeline's errors (`pipeline_error_model`). In a
module of their own so that numba loads with the first sensor made, not with every import of the
scenes (`fvtree validate` reads the scene table)."""

from __future__ import annotations

import numpy as np
from numba import njit

from perception.sums import pairwise_sum
from perception.wrench_kernel import mean_wrench_into


@njit(cache=True, nogil=True)
def marker_field(rest, basis, shear_x, shear_y, spread, turn, growth, out):  # pragma: no cover - compiled
    """`out` (N, 3): x, y, size of the markers, `rest` (3N,) moved by the loads through `basis` (5, 3N).
    The caller makes `out`: an array a compiled function returns costs Python ~1-2 us to box."""
    loads = np.array([shear_x, shear_y, spread, turn, growth])
    out.reshape(-1)[:] = rest + np.dot(loads, basis)


@njit(cache=True, nogil=True, error_model="numpy")
def observe(exact, prev, estimate, tracked, noise, alpha, origin, terms, position, size,
            wrench):  # pragma: no cover - compiled
    """One tick of the marker errors, in one pass: the tracker's `estimate` (N, 3, updated in place)
    follows `exact` with the first-order lag `alpha` where `tracked`; writes the reported (N, 2)
    `position` and (N,) `size` with `noise` (N, 3) added, and into `wrench` (6,) the force and torque
    the wrench estimator makes of the tracked markers (`origin`, `terms`: `perception.wrench`);
    returns the mean |motion| of the exact positions since `prev` (summed in numpy's pairwise order,
    as `image_motion` sums them). The caller makes the output arrays (see `marker_field`)."""
    n = len(exact)
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
    mean_wrench_into(position, origin, terms, tracked, wrench)
    return pairwise_sum(moved, 0, 2 * n) / (2 * n)
