"""Rendered benchmark sequences with ground truth.

The benchmark is a development tool that composes the simulated camera (`drivers.sim.models.synthetic_camera`) with
the pipeline; it is the one place in `perception` that imports `drivers`, and nothing in the
pipeline imports the benchmark.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.models.synthetic_camera import Appearance, RenderedFrame, SyntheticFingerVision
from perception.state import ObjectInfo

OBJECT = ObjectInfo(True, 0.25, np.array([0.06, -0.03]), 0.4)


@dataclass
class Sequence:
    """Frames with ground truth, plus the clean calibration frames they start from."""

    calibration: list[np.ndarray]
    frames: list[RenderedFrame]
    origin: np.ndarray  # (N, 2) true marker origins


class Bench:
    """A simulated right fingertip (contact model without position noise) and its camera."""

    def __init__(self, seed: int = 0):
        self.model = SensorModel("right", noise_px=0.0)
        self.camera = SyntheticFingerVision(self.model.origin, self.model.marker_size, seed=seed)

    def calibration(self, look: Appearance = Appearance(noise=2.0), n: int = 10) -> list[np.ndarray]:
        return [self.camera.render(appearance=look).image for _ in range(n)]

    def field(self, contact: FingerContact) -> tuple[np.ndarray, np.ndarray]:
        m = self.model.state(contact, 0.0).markers
        return m.position, m.size

    def press(self, frames: int, look: Appearance, peak: float = 40.0,
              obj: ObjectInfo | None = None) -> Sequence:
        """Press in (first third), hold (second third), release (last third)."""
        cal = self.calibration(look)
        out = []
        third = max(frames // 3, 1)
        for k in range(frames):
            ramp = min(k / third, 1.0) if k < 2 * third else max(0.0, 1.0 - (k - 2 * third) / third)
            load = peak * 0.5 * (1.0 - np.cos(np.pi * ramp))
            pos, size = self.field(FingerContact(load, np.array([0.3, 0.1]) * load))
            out.append(self.camera.render(pos, size, obj, appearance=look))
        return Sequence(cal, out, self.model.origin)

    def shear_ramp(self, frames: int, displacement: float, look: Appearance) -> Sequence:
        """Shear growing to `displacement` px at the patch centre over the first half, then held."""
        gain = self.model.shear_gain
        out = []
        for k in range(frames):
            d = displacement * min(1.0, 2.0 * k / max(frames - 1, 1))
            pos, size = self.field(FingerContact(0.0, np.array([d / gain, 0.0])))
            out.append(self.camera.render(pos, size, appearance=look))
        return Sequence(self.calibration(), out, self.model.origin)

    def step(self, frames: int, at: int, step_px: float, look: Appearance) -> Sequence:
        """Markers at rest, then all shifted by `step_px` along x from frame `at` on."""
        out = [self.camera.render(self.model.origin + [step_px * (k >= at), 0.0], appearance=look)
               for k in range(frames)]
        return Sequence(self.calibration(look), out, self.model.origin)

    def slip(self, frames: int, look: Appearance, speed: float = 2.0, period: int = 30):
        """Object alternately resting and sliding (`speed` px/frame) in blocks of `period` frames,
        with a hand moving behind it while it rests and a flickering light; returns (frames, labels)."""
        rng = np.random.default_rng(7)
        shift, images, labels = 0.0, [], []
        for k in range(frames):
            sliding = (k // period) % 2 == 1
            shift += speed if sliding else 0.0
            hand = None if sliding else np.array([40.0 + 4.0 * (k % period), 200.0 - 2.0 * (k % period)])
            flicker = Appearance(look.noise, look.gain * (1.0 + 0.03 * rng.standard_normal()), look.gradient,
                                 look.blur)
            images.append(self.camera.render(obj=OBJECT, obj_shift=shift, appearance=flicker,
                                             distractor=hand).image)
            labels.append(sliding)
        return images, np.array(labels)

    def object_samples(self, n: int = 3) -> list[RenderedFrame]:
        """Frames of the object at rest, to mark the colour model on (the original's hand edit)."""
        return [self.camera.render(obj=OBJECT, appearance=Appearance(noise=2.0)) for _ in range(n)]
