"""The simulator's rotation maths gives numpy's results, to the bit where numpy's order of operations is
fixed: its shortcuts (Python floats, kept results,
ndarray.dot) must not change a simulated run."""

from __future__ import annotations

import math

import numpy as np

from drivers.sim.transforms import compose, homogeneous, matrix_to_rotvec, rigid_inverse, rotation_entries

EPS = np.finfo(float).eps


def _numpy_half_turn(m: np.ndarray) -> np.ndarray:
    """The rotation vector of a rotation `m` near a half turn, worked out in numpy."""
    angle = math.acos(max(-1.0, min(1.0, (m[0, 0] + m[1, 1] + m[2, 2] - 1.0) / 2.0)))
    axis = np.sqrt(np.maximum((np.diag(m) + 1.0) / 2.0, 0.0))
    i = int(np.argmax(axis))
    for j in ((i + 1) % 3, (i + 2) % 3):
        axis[j] = math.copysign(axis[j], m[i, j] + m[j, i])
    return axis / np.linalg.norm(axis) * angle


def test_the_rotation_vector_near_a_half_turn_is_numpys_but_for_the_last_bits():
    """numpy's 3-vector norm is a BLAS dot product, whose order of operations (and so its last bits)
    depends on the processor's kernel; the shortcut sums in one fixed order, the same on every
    machine. Within a few machine epsilons of the vector's length of numpy's formula."""
    rng = np.random.default_rng(0)
    for _ in range(2000):
        axis = rng.normal(size=3)
        if rng.random() < 0.5:
            axis[rng.integers(3)] = 0.0  # an axis in a coordinate plane
        turn = math.pi if rng.random() < 0.2 else math.pi - rng.uniform(0.0, 1e-6)
        m = homogeneous([0.0, 0.0, 0.0, *(axis / np.linalg.norm(axis) * turn)])[:3, :3]
        if math.pi - math.acos(max(-1.0, min(1.0, (m[0, 0] + m[1, 1] + m[2, 2] - 1.0) / 2.0))) < 1e-6:
            np.testing.assert_allclose(matrix_to_rotvec(m), _numpy_half_turn(m), rtol=0, atol=4 * EPS * math.pi)


def test_a_kept_rotation_is_told_apart_from_one_that_differs_only_in_the_sign_of_a_zero():
    assert math.copysign(1.0, rotation_entries([0.0, 0.0, 1.0])[6]) == 1.0
    assert math.copysign(1.0, rotation_entries([-0.0, 0.0, 1.0])[6]) == -1.0


def test_compose_gives_the_bits_of_the_matrix_product():
    rng = np.random.default_rng(1)
    for _ in range(2000):
        a, b = (homogeneous([*rng.uniform(-1.0, 1.0, 3), *rng.normal(size=3)]) for _ in range(2))
        assert compose(a, b).tobytes() == (a @ b).tobytes()
        assert compose(rigid_inverse(a), b).tobytes() == (rigid_inverse(a) @ b).tobytes()
