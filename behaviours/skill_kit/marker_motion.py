"""The compiled kernel of `hand.slip_beyond_marker_flow`: how far the markers tracked in two states
moved. In a module of its own so that numba loads with the first run that needs it, not with every
import of the skill kit (`fvtree validate` imports the skills' declarations only)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from perception.sums import pairwise_sum


@njit(cache=True, nogil=True)
def tracked_motion(position, before, valid, was_valid):  # pragma: no cover - compiled
    """(markers tracked in both states, the sum of their distances moved), summed in numpy's order
    over the tracked ones: a load scan asks twice a tick, and numpy's eight small-array calls cost
    several times the loop."""
    distances = np.empty(len(valid))
    tracked = 0
    for i in range(len(valid)):
        if valid[i] and was_valid[i]:
            dx, dy = position[i, 0] - before[i, 0], position[i, 1] - before[i, 1]
            distances[tracked] = math.sqrt(dx * dx + dy * dy)
            tracked += 1
    return tracked, pairwise_sum(distances, 0, tracked)
