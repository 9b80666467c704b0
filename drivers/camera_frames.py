"""The newest camera image of each finger, as a perception source last saw it: what the run's
recording takes its camera frames from (rendered frames in pixel mode, real cameras on a real cell).

A perception source that works on images offers one as its `frames` attribute (`frames_of`); it
keeps references, never copies, so keeping costs nothing on the tick path. The frames are handed
out JPEG-encoded, what a recording stores: encoded when asked (a few times a second), and by
whoever holds the image (pixel mode's worker processes encode their finger's: `pixel_workers`)."""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np


class LatestFrames:
    """The newest frame (BGR image, cell-clock stamp) of each finger the perception source processed."""

    def __init__(self):
        self._images: dict[str, tuple[np.ndarray, float]] = {}

    def keep(self, finger: str, image: np.ndarray, stamp: float) -> None:
        """Remember `image` as the finger's newest frame (a reference, not a copy)."""
        self._images[finger] = (image, stamp)

    def jpegs(self, quality: int) -> dict[str, tuple[bytes, float]]:
        """Finger -> (JPEG bytes at `quality`, stamp) of each finger's newest frame, encoded now."""
        encoded = {}
        for finger, (image, stamp) in list(self._images.items()):
            jpeg = jpeg_of(image, quality)
            if jpeg is not None:
                encoded[finger] = (jpeg, stamp)
        return encoded


def jpeg_of(image: np.ndarray, quality: int) -> bytes | None:
    """`image` as JPEG bytes at `quality` (0-100), or None when OpenCV cannot encode it."""
    ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    return jpeg.tobytes() if ok else None


def frames_of(sense: Any) -> LatestFrames | None:
    """The frames a perception source offers, or None (signal-level sources have no images)."""
    frames = getattr(sense, "frames", None)
    return frames if isinstance(frames, LatestFrames) else None
