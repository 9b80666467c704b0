"""Sensor noise of the synthetic FingerVision camera, drawn once and sampled per frame.

Drawing a fresh Gaussian field for every frame costs more than the rest of a frame; instead a few
seeded noise frames, slightly larger than the image, are drawn once (grey noise: the same on all
three channels, rounded to whole grey levels) and each frame adds a window of the next one at a
random offset. Pixels see independent values from frame to frame (each window position samples
other noise pixels), and consecutive frames never use the same noise frame.
"""

from __future__ import annotations

import cv2
import numpy as np

FRAMES = 4  # noise frames in a bank
MARGIN = 16  # px the noise frames exceed the image on each axis: (MARGIN + 1)^2 offsets per frame
OFFSETS = 256  # window offsets drawn at a time


class NoiseBank:
    """Seeded Gaussian noise of standard deviation `std` grey levels for (W, H) images."""

    def __init__(self, std: float, image_size: tuple[int, int], seed: int):
        w, h = image_size
        self._size = (h, w)
        self._rng = np.random.default_rng(seed)
        grey = np.rint(self._rng.standard_normal((FRAMES, h + MARGIN, w + MARGIN), np.float32) * std)
        grey = np.clip(grey, -255, 255)
        # Saturating adds work on uint8 only: keep the positive and negative parts apart.
        self._up = np.repeat(np.maximum(grey, 0).astype(np.uint8)[..., None], 3, axis=3)
        self._down = np.repeat(np.maximum(-grey, 0).astype(np.uint8)[..., None], 3, axis=3)
        self._offsets: list[list[int]] = []
        self._frames = 0

    def add(self, clean: np.ndarray) -> np.ndarray:
        """A new (H, W, 3) uint8 image: `clean` plus the next noise window, saturated to 0..255."""
        if not self._offsets:
            self._offsets = self._rng.integers(0, MARGIN + 1, (OFFSETS, 2)).tolist()
        dy, dx = self._offsets.pop()
        k = self._frames % FRAMES
        self._frames += 1
        h, w = self._size
        out = np.empty_like(clean)
        cv2.add(clean, self._up[k, dy:dy + h, dx:dx + w], dst=out)
        cv2.subtract(out, self._down[k, dy:dy + h, dx:dx + w], dst=out)
        return out
