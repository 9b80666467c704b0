"""The compiled mean wrench of `perception.wrench.wrench`, in a module of its own so that numba loads
with the first wrench computed, not with every import of `perception.wrench`."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def mean_wrench(position, origin, terms, valid):  # pragma: no cover - compiled
    """(force, torque): the mean over the valid markers of the seven products of [dx, normal, dy,
    normal, dx, normal, dy] (normal = |(dx, dy)|) with `terms`, summed marker by marker in one pass
    (the seventh added to the fifth: torque about the finger normal); zeros when none is valid. It
    runs for every finger on every tick, and numpy's small-array calls cost more than the sums."""
    sums = np.empty(6)
    mean_wrench_into(position, origin, terms, valid, sums)
    return sums[:3], sums[3:]


@njit(cache=True, nogil=True, error_model="numpy")
def mean_wrench_into(position, origin, terms, valid, sums):  # pragma: no cover - compiled
    """`mean_wrench` written into `sums` (6,): force, then torque. For a caller that hands the
    kernel its output arrays: each array a compiled function returns costs Python ~1-2 us to box."""
    sums[:] = 0.0
    count = 0
    for i in range(len(valid)):
        if not valid[i]:
            continue
        count += 1
        dx, dy = position[i, 0] - origin[i, 0], position[i, 1] - origin[i, 1]
        normal = math.hypot(dx, dy)
        sums[0] += dx * terms[i, 0]
        sums[1] += normal * terms[i, 1]
        sums[2] += dy * terms[i, 2]
        sums[3] += normal * terms[i, 3]
        sums[4] += dx * terms[i, 4] + dy * terms[i, 6]
        sums[5] += normal * terms[i, 5]
    if count:
        sums /= count
