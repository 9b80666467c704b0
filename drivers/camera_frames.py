"""The newest camera image of each finger, as a perception source last saw it: what the run's
recording takes its camera frames from (rendered frames in pixel mode, real cameras on a real cell).

A perception source that works on images offers one as its `frames` attribute (`frames_of`); it
keeps references, never copies, so keeping costs nothing on the tick path."""

from __future__ import annotations

from typing import Any

import numpy as np


class LatestFrames:
    """Finger -> (BGR image, cell-clock stamp) of the newest frame the perception source processed."""

    def __init__(self):
        self.images: dict[str, tuple[np.ndarray, float]] = {}

    def keep(self, finger: str, image: np.ndarray, stamp: float) -> None:
        self.images[finger] = (image, stamp)


def frames_of(sense: Any) -> LatestFrames | None:
    """The frames a perception source offers, or None (signal-level sources have no images)."""
    frames = getattr(sense, "frames", None)
    return frames if isinstance(frames, LatestFrames) else None
