"""Closed-form rotation-vector maths for the simulator's per-tick hot path.

scipy's Rotation costs tens of microseconds per call; these cost about one, which keeps a
simulated run well over 100x faster than real time.
"""

from __future__ import annotations

import math

import numpy as np


def rotvec_to_matrix(r) -> np.ndarray:
    """Rodrigues' formula."""
    x, y, z = float(r[0]), float(r[1]), float(r[2])
    angle = math.sqrt(x * x + y * y + z * z)
    if angle < 1e-12:
        return np.eye(3)
    x, y, z = x / angle, y / angle, z / angle
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return np.array([
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ])


def matrix_to_rotvec(m: np.ndarray) -> np.ndarray:
    """Inverse of Rodrigues' formula, stable near 0 and pi."""
    cos = max(-1.0, min(1.0, (m[0, 0] + m[1, 1] + m[2, 2] - 1.0) / 2.0))
    angle = math.acos(cos)
    if angle < 1e-9:
        return np.zeros(3)
    if math.pi - angle < 1e-6:
        # Near a half turn the axis comes from the diagonal of (R + I) / 2.
        axis = np.sqrt(np.maximum((np.diag(m) + 1.0) / 2.0, 0.0))
        i = int(np.argmax(axis))
        axis[(i + 1) % 3] = math.copysign(axis[(i + 1) % 3], m[i, (i + 1) % 3] + m[(i + 1) % 3, i])
        axis[(i + 2) % 3] = math.copysign(axis[(i + 2) % 3], m[i, (i + 2) % 3] + m[(i + 2) % 3, i])
        return axis / np.linalg.norm(axis) * angle
    v = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
    return v * (angle / (2.0 * math.sin(angle)))


def homogeneous(pose) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = rotvec_to_matrix(pose[3:])
    t[:3, 3] = pose[:3]
    return t


def rigid_inverse(t: np.ndarray) -> np.ndarray:
    inv = np.eye(4)
    rt = t[:3, :3].T
    inv[:3, :3] = rt
    inv[:3, 3] = -rt @ t[:3, 3]
    return inv


def pose_of(t: np.ndarray) -> np.ndarray:
    return np.concatenate([t[:3, 3], matrix_to_rotvec(t[:3, :3])])
