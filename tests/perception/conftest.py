"""Rendered FingerVision scenes with ground truth, shared by the perception tests (seeded)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.models.synthetic_camera import Appearance, SyntheticFingerVision
from perception.config import load_config
from perception.fingervision import FingerVision
from perception.sensor_profile import load_profile

REAL_CLIP = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "fv_demo" / "cam1_0002.m4v"


class Scene:
    """A simulated sensor (contact model without noise) and its camera."""

    def __init__(self, seed: int = 3, noise: float = 4.0):
        # the former simulated sensor: these scenarios are written in its pixels (loads of 40-75 N that
        # move its markers a few px; the calibrated sensor moves them 5x more under normal load)
        self.model = SensorModel("right", load_profile("simulated_2025"), noise_px=0.0)
        self.camera = SyntheticFingerVision(self.model.origin, self.model.marker_size, seed=seed)
        self.look = Appearance(noise=noise)

    def calibration(self, n: int = 10) -> list[np.ndarray]:
        return [self.camera.render(appearance=self.look).image for _ in range(n)]

    def press(self, frames: int = 30, peak: float = 40.0):
        """Frames of a contact pressing in, holding and releasing; yields (image, truth)."""
        for k in range(frames):
            load = peak * np.sin(np.pi * k / (frames - 1))
            field = self.model.state(FingerContact(normal=load, shear=np.array([0.3, 0.1]) * load), 0.0)
            frame = self.camera.render(field.markers.position, field.markers.size, appearance=self.look)
            yield frame.image, frame.truth

    def pipeline(self, preset: str = "fast", **overrides) -> FingerVision:
        fv = FingerVision(load_config(preset, **overrides), "right")
        fv.calibrate(self.calibration())
        return fv


def match(calibrated: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Index of the true marker nearest each calibrated origin (asserted to be a real match)."""
    d = np.linalg.norm(calibrated[:, None, :] - truth[None, :, :], axis=2)
    assert d.min(axis=1).max() < 1.0, "a calibrated marker matches no rendered marker"
    return d.argmin(axis=1)


@pytest.fixture
def scene() -> Scene:
    return Scene()
