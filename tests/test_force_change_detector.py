"""`ForceChangeDetector` (gentle_grasp's and handover's contact rule): the limit a marker must pass is
set by the rest noise the reference frames show, pooled and per marker, so a noisy skin or a few
noisy markers do not feel a touch that a pressed patch of markers does."""

from __future__ import annotations

import numpy as np

from behaviours.skill_kit.control import ForceChangeDetector, marker_noise

MARKERS = 60


def rest(rng: np.random.Generator, sigma: np.ndarray) -> np.ndarray:
    """One frame of marker forces at rest: per-marker Gaussian noise of `sigma` px per axis."""
    return rng.normal(0.0, 1.0, (MARKERS, 2)) * sigma[:, None]


def test_a_few_noisy_markers_do_not_fire_but_a_pressed_patch_does():
    rng = np.random.default_rng(0)
    sigma = np.full(MARKERS, 0.05)
    sigma[:12] = 0.4  # a dozen markers at the image's edge, under glare: 8x the others' noise
    detector = ForceChangeDetector(threshold=0.3, min_markers=10, reference_frames=10)
    fired = [detector.update(rest(rng, sigma), rest(rng, sigma)) for _ in range(300)]
    assert not any(fired)
    pressed = rest(rng, sigma)
    pressed[20:40] += [1.5, 0.0]  # 20 quiet markers pushed 1.5 px: a touch
    assert detector.update(pressed, rest(rng, sigma))


def test_marker_noise_is_each_markers_own_spread():
    frames = np.zeros((4, 3, 2))
    frames[:, 1, 0] = [0.0, 1.0, 0.0, 1.0]
    noise = marker_noise(frames)
    assert noise[0] == 0.0 and noise[2] == 0.0
    assert np.isclose(noise[1], np.sqrt(np.var([0, 1, 0, 1], ddof=1) / 2))
    assert np.array_equal(marker_noise(frames[:1]), np.zeros(3))
