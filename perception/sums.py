"""Sums in compiled loops that add in the order numpy's `add.reduce` does, so that a loop moved
from numpy into a compiled kernel keeps its results to the bit (and the simulation its digest)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def pairwise_sum(a, start, n):  # pragma: no cover - compiled
    """Sum of a[start:start + n] in the order numpy's add.reduce uses, so that compiled and numpy
    sums agree to the bit: blocks of up to 128 summed by `_block_sum`, longer runs split in halves
    (a multiple of 8 on the left) and the halves' sums added; the halving runs on an explicit stack
    (numba's cache does not hold recursive functions)."""
    frames = np.empty((64, 3), np.int64)  # start, length, halves done; depth log2(n / 128)
    sums = np.empty(64)
    frames[0, 0], frames[0, 1], frames[0, 2] = start, n, 0
    top, done = 1, 0
    while top:
        s, m, step = frames[top - 1]
        if m <= 128:
            sums[done] = _block_sum(a, s, m)
            done += 1
            top -= 1
            continue
        half = m // 2 - (m // 2) % 8
        if step == 2:
            sums[done - 2] += sums[done - 1]
            done -= 1
            top -= 1
            continue
        frames[top - 1, 2] = step + 1
        frames[top, 0], frames[top, 1], frames[top, 2] = (s, half, 0) if step == 0 else (s + half, m - half, 0)
        top += 1
    return sums[0]


@njit(cache=True, nogil=True, error_model="numpy")
def _block_sum(a, start, n):  # pragma: no cover - compiled
    """numpy's sum of a block of at most 128: a plain loop below 8, else eight running sums."""
    if n < 8:
        total = 0.0
        for i in range(start, start + n):
            total += a[i]
        return total
    r0, r1, r2, r3, r4, r5, r6, r7 = a[start:start + 8]
    i = start + 8
    end = start + n - n % 8
    while i < end:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for k in range(i, start + n):
        total += a[k]
    return total
