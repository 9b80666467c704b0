"""The window tracker's per-marker loops, compiled (numba): one pass over each marker's window and
one small solve per neighbourhood, where numpy would make some thirty passes over small arrays
(on the 2-core machine: ~25 instead of ~330 us a frame for 37 markers).

Kernels are compiled at first use and cached beside this file (`__pycache__`), so a process after
the first loads them in milliseconds.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def measure_windows(grey, centre, rows, disc, ring_in, half):  # pragma: no cover - compiled
    """For the markers `rows`, each in the (2 half + 1)^2 window of `grey` (uint8) around its `centre`
    (rounded, and moved inside the image): ((n, 2) centroid, diameter, contrast, dark-pixel count,
    dark share of the 2 px wide ring from `ring_in[k]` px out); see `WindowTracker._window`."""
    n = len(rows)
    size = 2 * half + 1
    height, width = grey.shape
    xy = np.empty((n, 2))
    diameter = np.empty(n)
    contrast = np.empty(n)
    count = np.empty(n, np.int64)
    ring_dark = np.empty(n)
    p = np.empty((size, size), np.float32)
    histogram = np.empty(256, np.int64)
    m = 2 * (size - 1)  # the border has 4 (size - 1) pixels: its median is the mean of the m-th and m+1-th
    for k in range(n):
        i = rows[k]
        cx = min(max(int(np.rint(centre[k, 0])), half), width - 1 - half)
        cy = min(max(int(np.rint(centre[k, 1])), half), height - 1 - half)
        x0, y0 = cx - half, cy - half
        dark = np.float32(255.0)
        for r in range(size):
            for c in range(size):
                v = np.float32(grey[y0 + r, x0 + c])
                p[r, c] = v
                dark = min(dark, v)
        # The window's border: its median is the local background, robust to a feature touching it
        # (from a histogram of its 8-bit values: exact, and quicker than a sort).
        histogram[:] = 0
        for c in range(size):
            histogram[grey[y0, x0 + c]] += 1
            histogram[grey[y0 + size - 1, x0 + c]] += 1
        for r in range(1, size - 1):
            histogram[grey[y0 + r, x0]] += 1
            histogram[grey[y0 + r, x0 + size - 1]] += 1
        low = high = -1
        seen = 0
        for value in range(256):
            seen += histogram[value]
            if low < 0 and seen >= m:
                low = value
            if seen >= m + 1:
                high = value
                break
        bg = np.float32(0.5) * (np.float32(low) + np.float32(high))
        level = np.float32(0.5) * (bg + dark)
        # Depth below half-way inside the marker's disc: the weights of the centroid.
        total = 0.0
        mx = 0.0
        my = 0.0
        inside = 0
        core = 0.0
        dark_ring = 0
        ring_size = 0
        inner, outer = ring_in[k] * ring_in[k], (ring_in[k] + 2.0) * (ring_in[k] + 2.0)
        for r in range(size):
            for c in range(size):
                v = p[r, c]
                d2 = float((r - half) * (r - half) + (c - half) * (c - half))
                if inner < d2 <= outer:
                    ring_size += 1
                    if v < level:
                        dark_ring += 1
                if not disc[i, r, c] or v >= level:
                    continue
                below = level - v
                total += below
                mx += below * (c - half)
                my += below * (r - half)
                inside += 1
                core += v
        core = core / max(inside, 1)
        # Covered share of each disc pixel between background and the marker's core: its area.
        span = max(bg - core, 1.0)
        area = 0.0
        for r in range(size):
            for c in range(size):
                if disc[i, r, c]:
                    cover = (bg - p[r, c]) / span
                    if cover > 0.15:
                        area += min(cover, 1.0)
        total += 1e-6
        xy[k, 0] = cx + mx / total
        xy[k, 1] = cy + my / total
        diameter[k] = 2.0 * math.sqrt(area / math.pi)
        contrast[k] = bg - dark
        count[k] = inside
        ring_dark[k] = dark_ring / max(ring_size, 1)
    return xy, diameter, contrast, count, ring_dark


@njit(cache=True, nogil=True, error_model="numpy")
def predict_local(coef, x, neighbours, rows, displacement, trusted, prior):  # pragma: no cover - compiled
    """((R, 2) displacement predicted for the markers `rows` by their trusted neighbours' local affine
    fit, (R,) count of those neighbours); see `LocalFit.predict`. A fully trusted neighbourhood uses
    its fixed combination `coef` (N, k); any other solves its weighted ridge normal equations
    (sum_j x_j x_j^T + prior) b = sum_j x_j d_j over the trusted neighbours j for b (3 x 2), whose
    first row is the prediction. x: (N, k, 3) fit rows, prior: (3, 3)."""
    n, k = len(rows), neighbours.shape[1]
    out = np.zeros((n, 2))
    count = np.zeros(n, np.int64)
    a = np.empty((3, 3))
    b = np.empty((3, 2))
    for r in range(n):
        i = rows[r]
        for j in range(k):
            if trusted[neighbours[i, j]]:
                count[r] += 1
        if count[r] == k:
            for j in range(k):
                q = neighbours[i, j]
                out[r, 0] += coef[i, j] * displacement[q, 0]
                out[r, 1] += coef[i, j] * displacement[q, 1]
            continue
        a[:, :] = prior
        b[:, :] = 0.0
        for j in range(k):
            q = neighbours[i, j]
            if not trusted[q]:
                continue
            for u in range(3):
                for v in range(3):
                    a[u, v] += x[i, j, u] * x[i, j, v]
                b[u, 0] += x[i, j, u] * displacement[q, 0]
                b[u, 1] += x[i, j, u] * displacement[q, 1]
        # Gaussian elimination with partial pivoting, then back substitution down to the first row.
        for col in range(3):
            pivot = col
            for row in range(col + 1, 3):
                if abs(a[row, col]) > abs(a[pivot, col]):
                    pivot = row
            if pivot != col:
                for v in range(3):
                    a[col, v], a[pivot, v] = a[pivot, v], a[col, v]
                for v in range(2):
                    b[col, v], b[pivot, v] = b[pivot, v], b[col, v]
            for row in range(col + 1, 3):
                f = a[row, col] / a[col, col]
                for v in range(col, 3):
                    a[row, v] -= f * a[col, v]
                for v in range(2):
                    b[row, v] -= f * b[col, v]
        for v in range(2):
            s2 = b[2, v] / a[2, 2]
            s1 = (b[1, v] - a[1, 2] * s2) / a[1, 1]
            out[r, v] = (b[0, v] - a[0, 1] * s1 - a[0, 2] * s2) / a[0, 0]
    return out, count


@njit(cache=True, nogil=True, error_model="numpy")
def kalman_step(pos, vel, size, p00, p01, p11, ps, z_pos, z_size, valid, q, r, dt):  # pragma: no cover - compiled
    """One predict-correct step of every marker's filter, in place (see `MarkerKalman.update`):
    measured markers move with their velocity and take their measurement; unmeasured ones hold still
    while their covariance grows. Returns the (N, 2) innovations (0 without a measurement) and the
    (N,) innovation variances."""
    n = len(valid)
    nu = np.zeros((n, 2))
    s = np.empty(n)
    for i in range(n):
        if valid[i]:
            pos[i, 0] += dt * vel[i, 0]
            pos[i, 1] += dt * vel[i, 1]
            p00[i] += 2.0 * dt * p01[i] + dt * dt * p11[i]
            p01[i] += dt * p11[i]
        p00[i] += q
        p11[i] += q
        ps[i] += q
        s[i] = p00[i] + r
        if not valid[i]:
            continue
        k0, k1 = p00[i] / s[i], p01[i] / s[i]
        for axis in range(2):
            nu[i, axis] = z_pos[i, axis] - pos[i, axis]
            pos[i, axis] += k0 * nu[i, axis]
            vel[i, axis] += k1 * nu[i, axis]
        p11[i] -= k1 * p01[i]
        p01[i] *= 1.0 - k0
        p00[i] *= 1.0 - k0
        ks = ps[i] / (ps[i] + r)
        size[i] += ks * (z_size[i] - size[i])
        ps[i] *= 1.0 - ks
    return nu, s


@njit(cache=True, nogil=True, error_model="numpy")
def near_trusted(xy, ok, distance):  # pragma: no cover - compiled
    """(N,) markers within `distance` of another marker that is `ok` (see `WindowTracker._clash`)."""
    n = len(ok)
    near = np.zeros(n, np.bool_)
    limit = distance * distance
    for j in range(n):
        if not ok[j]:
            continue
        for i in range(n):
            if i != j:
                dx, dy = xy[i, 0] - xy[j, 0], xy[i, 1] - xy[j, 1]
                if dx * dx + dy * dy < limit:
                    near[i] = True
    return near


@njit(cache=True, nogil=True, error_model="numpy")
def moving_hoods(nu, valid, neighbours, gate):  # pragma: no cover - compiled
    """(N,) markers whose neighbourhood (itself and its `neighbours`) moves: m |mean innovation|^2 /
    sigma^2 above `gate` over its m >= 3 measured markers, sigma^2 from this frame's median spread of
    the innovations about their neighbourhoods' means; see `MarkerKalman._moving`."""
    n, k = neighbours.shape
    count = np.zeros(n)
    mean = np.zeros((n, 2))
    for i in range(n):
        if valid[i]:
            count[i] += 1.0
            mean[i, 0] += nu[i, 0]
            mean[i, 1] += nu[i, 1]
        for j in range(k):
            q = neighbours[i, j]
            if valid[q]:
                count[i] += 1.0
                mean[i, 0] += nu[q, 0]
                mean[i, 1] += nu[q, 1]
        mean[i, 0] /= max(count[i], 1.0)
        mean[i, 1] /= max(count[i], 1.0)
    spread = np.empty(n)
    m = 0
    for i in range(n):
        if valid[i]:
            spread[m] = (nu[i, 0] - mean[i, 0]) ** 2 + (nu[i, 1] - mean[i, 1]) ** 2
            m += 1
    moving = np.zeros(n, np.bool_)
    if m < 3:
        return moving
    # The (upper) median; of chi2(2) it is 2 ln 2 sigma^2 per axis.
    sigma2 = max(np.sort(spread[:m])[m // 2] / (2.0 * math.log(2.0)), 1e-6)
    for i in range(n):
        stat = count[i] * (mean[i, 0] ** 2 + mean[i, 1] ** 2) / sigma2
        moving[i] = valid[i] and count[i] >= 3 and stat > gate
    return moving


def warm_up() -> None:
    """Load every kernel here now, for the argument types the tracker and the filter pass (compiled at
    first use on a machine and cached; loading costs ~0.5 s in a fresh process): a pipeline calls this
    when it is made, so that its first frame does not pay for it."""
    one, pair, hood = np.zeros(1), np.zeros((1, 2)), np.zeros((1, 1), np.int64)
    yes, rows = np.ones(1, np.bool_), np.zeros(1, np.int64)
    window = np.ones((1, 3, 3), np.bool_)
    measure_windows(np.zeros((3, 3), np.uint8), pair, rows, window, one, 1)
    predict_local(np.zeros((1, 1)), np.zeros((1, 1, 3)), hood, rows, pair, yes, np.eye(3))
    near_trusted(pair, yes, 1.0)
    kalman_step(pair, pair.copy(), one, one.copy(), one.copy(), one.copy(), one.copy(), pair.copy(), one.copy(),
                yes, 0.1, 0.1, 0.1)
    moving_hoods(pair, yes, hood, 1.0)
