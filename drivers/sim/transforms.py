"""Closed-form rotation-vector maths for the simulator's per-tick hot path.

scipy's Rotation costs tens of microseconds per call; these cost about one, which keeps a
simulated run well over 100x faster than real time: the entries are worked out on Python floats
and each result is made with one array call.
"""

from __future__ import annotations

import functools
import math
import struct

import numpy as np

IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
KEPT = 64  # rotations each of `rotation_entries` and `_rotvec` keeps (the ones asked about last)
_VECTOR, _MATRIX = struct.Struct("3d"), struct.Struct("9d")  # a rotation vector, a rotation's entries


def rotation_entries(r) -> tuple[float, ...]:
    """The 9 entries (row by row) of the rotation by rotation vector `r` (Rodrigues' formula)."""
    return _rotation(_VECTOR.pack(*(r.tolist() if isinstance(r, np.ndarray) else r)))


@functools.lru_cache(maxsize=KEPT)
def _rotation(vector: bytes) -> tuple[float, ...]:
    """`rotation_entries` of the rotation vector packed in `vector`, kept for the last few dozen
    vectors (compared as their bytes): the arm and the element it holds mostly move without
    turning, so most ticks ask again for a rotation worked out before."""
    x, y, z = _VECTOR.unpack(vector)
    angle = math.sqrt(x * x + y * y + z * z)
    if angle < 1e-12:
        return IDENTITY
    x, y, z = x / angle, y / angle, z / angle
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return (c + x * x * t, x * y * t - z * s, x * z * t + y * s,
            y * x * t + z * s, c + y * y * t, y * z * t - x * s,
            z * x * t - y * s, z * y * t + x * s, c + z * z * t)


def rotvec_to_matrix(r) -> np.ndarray:
    """Rodrigues' formula."""
    return np.array(rotation_entries(r)).reshape(3, 3)


def matrix_to_rotvec(m: np.ndarray) -> np.ndarray:
    """Inverse of Rodrigues' formula, stable near 0 and pi."""
    return np.array(_rotvec(m.tolist()))


def _rotvec(rows: list[list[float]]) -> tuple[float, float, float]:
    """`matrix_to_rotvec` of the top-left 3x3 block of a matrix given by its rows."""
    (m00, m01, m02, *_), (m10, m11, m12, *_), (m20, m21, m22, *_) = rows[:3]
    return _rotvec_of(_MATRIX.pack(m00, m01, m02, m10, m11, m12, m20, m21, m22))


@functools.lru_cache(maxsize=KEPT)
def _rotvec_of(entries: bytes) -> tuple[float, float, float]:
    """`_rotvec` of the rotation whose entries (row by row) are packed in `entries`, kept for the last
    few dozen rotations (compared as their bytes), as a held element keeps its turn for many ticks."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = _MATRIX.unpack(entries)
    cos = max(-1.0, min(1.0, (m00 + m11 + m22 - 1.0) / 2.0))
    angle = math.acos(cos)
    if angle < 1e-9:
        return 0.0, 0.0, 0.0
    if math.pi - angle < 1e-6:
        return _half_turn_rotvec(((m00, m01, m02), (m10, m11, m12), (m20, m21, m22)), angle)
    k = angle / (2.0 * math.sin(angle))
    return (m21 - m12) * k, (m02 - m20) * k, (m10 - m01) * k


def _half_turn_rotvec(rows: tuple[tuple[float, ...], ...], angle: float) -> tuple[float, float, float]:
    """`_rotvec` near a half turn (`angle` about pi) of the rotation R with these `rows`, where the
    axis comes from the diagonal of (R + I) / 2: the signs of the two smaller entries from the
    off-diagonal sums of the largest one's row and column. On Python floats in numpy's order of
    operations (its 3-vector norm sums (x x + y y) + z z), as an element turned upside down by the
    tool is held that way for many ticks."""
    axis = [math.sqrt(max((rows[j][j] + 1.0) / 2.0, 0.0)) for j in range(3)]
    i = axis.index(max(axis))  # the first largest, as numpy's argmax
    for j in ((i + 1) % 3, (i + 2) % 3):
        axis[j] = math.copysign(axis[j], rows[i][j] + rows[j][i])
    norm = math.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
    return axis[0] / norm * angle, axis[1] / norm * angle, axis[2] / norm * angle


def homogeneous(pose) -> np.ndarray:
    """4x4 transform of a pose [x, y, z, rx, ry, rz]."""
    p = pose.tolist() if isinstance(pose, np.ndarray) else [float(v) for v in pose]
    r = rotation_entries(p[3:6])
    return np.array([r[0], r[1], r[2], p[0], r[3], r[4], r[5], p[1], r[6], r[7], r[8], p[2],
                     0.0, 0.0, 0.0, 1.0]).reshape(4, 4)


def inverse_entries(r: tuple[float, ...], p: list[float]) -> tuple[float, ...]:
    """The top 3 rows (row by row) of the inverse [R^T, -R^T p] of the rigid transform with rotation
    entries `r` (row by row) and translation `p`."""
    x, y, z = p[0], p[1], p[2]
    return (r[0], r[3], r[6], -(r[0] * x + r[3] * y + r[6] * z),
            r[1], r[4], r[7], -(r[1] * x + r[4] * y + r[7] * z),
            r[2], r[5], r[8], -(r[2] * x + r[5] * y + r[8] * z))


def rigid_inverse(t: np.ndarray) -> np.ndarray:
    """Inverse of a 4x4 rigid transform: [R^T, -R^T p]."""
    (r00, r01, r02, x), (r10, r11, r12, y), (r20, r21, r22, z) = t.tolist()[:3]
    return np.array([*inverse_entries((r00, r01, r02, r10, r11, r12, r20, r21, r22), [x, y, z]),
                     0.0, 0.0, 0.0, 1.0]).reshape(4, 4)


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The product a @ b of two 4x4 transforms: `ndarray.dot` makes the same BLAS call as the @
    operator (so the same bits) for well under half of its dispatch cost."""
    return a.dot(b)


def pose_of(t: np.ndarray) -> np.ndarray:
    """The pose [x, y, z, rx, ry, rz] of a 4x4 transform."""
    rows = t.tolist()
    return np.array([rows[0][3], rows[1][3], rows[2][3], *_rotvec(rows)])
