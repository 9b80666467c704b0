"""Rendered benchmark sequences with ground truth.

The benchmark is a development tool that composes the simulated camera (`drivers.sim.models.synthetic_camera`) with
the pipeline; it is the one place in `perception` that imports `drivers`, and nothing in the
pipeline imports the benchmark.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.models.synthetic_camera import Appearance, RenderedFrame, SyntheticFingerVision
from perception.state import ObjectInfo

OBJECT = ObjectInfo(True, 0.25, np.array([0.06, -0.03]), 0.4)
CALIBRATION_LOOK = Appearance(noise=2.0)
SHADES = {"dark": 0.45, "bright": 1.5}  # brightness of a uniform object over the skin's


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

    def calibration(self, look: Appearance = CALIBRATION_LOOK, n: int = 10) -> list[np.ndarray]:
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


def dense_layout(seed: int, pitch: float = 26.0, jitter: float = 1.5, radius: float = 105.0) -> np.ndarray:
    """(N, 2) marker origins of an independent test sensor: a denser, jittered hex grid (about 56
    markers, against the simulated finger's 37), so the bench does not only see the layout the
    pipeline was tuned on."""
    rng = np.random.default_rng(seed)
    w, h = 320, 240
    pts = []
    rows = int(radius // (pitch * 0.866)) + 1
    for r in range(-rows, rows + 1):
        y = r * pitch * 0.866
        for c in range(-int(radius // pitch) - 1, int(radius // pitch) + 2):
            x = c * pitch + (0.5 * pitch if r % 2 else 0.0)
            if x * x + y * y <= radius * radius:
                pts.append((w / 2 + x, h / 2 + y))
    origin = np.array(pts)
    return origin + rng.uniform(-jitter, jitter, origin.shape)


def blur_sigma(kernel_px: float) -> float:
    """Gaussian sigma of a blur `kernel_px` wide (OpenCV's rule for a kernel of that size; 0: none)."""
    return 0.0 if kernel_px <= 1 else 0.3 * ((kernel_px - 1) * 0.5 - 1) + 0.8


class PatternedCamera(SyntheticFingerVision):
    """The synthetic camera with a flat object pressed on the skin beneath the markers: a QR-like
    pattern of black and white squares (`pattern="qr"`), a uniformly dark one (`"dark"`) or a white
    sheet (`"bright"`), covering `share` of the sensor window; or thin dark edges (`"edges"`) starting
    next to `share` of the markers. The markers stay drawn on top."""

    def __init__(self, origin: np.ndarray, marker_size: float, seed: int, share: float, pattern: str,
                 cell: float = 9.0):
        super().__init__(origin, marker_size, seed=seed)
        rng = np.random.default_rng(seed + 101)
        w, h = self.image_size
        radius = self.window_radius * np.sqrt(min(max(share, 0.0), 1.0))  # a disc of that share
        angle = rng.uniform(0, 2 * np.pi)
        centre = self._centre + (self.window_radius - radius) * 0.6 * np.array([np.cos(angle), np.sin(angle)])
        inside = np.hypot(self._xx - centre[0], self._yy - centre[1]) <= radius
        if pattern == "qr":
            cells = rng.random((int(h / cell) + 2, int(w / cell) + 2)) < 0.5
            dark = cells[(self._yy / cell).astype(int), (self._xx / cell).astype(int)]
            shade = np.where(inside & dark, 0.12, 1.0)
        elif pattern == "edges":  # thin dark edges behind the skin, some running into markers
            shade = np.ones((h, w), np.float32)
            for start in origin[rng.choice(len(origin), max(1, int(share * len(origin))), replace=False)]:
                angle = rng.uniform(0, 2 * np.pi)
                a = start + (marker_size / 2 + 1) * np.array([np.cos(angle), np.sin(angle)])
                b = a + rng.uniform(12, 30) * np.array([np.cos(angle), np.sin(angle)])
                cv2.line(shade, tuple(int(v) for v in a), tuple(int(v) for v in b), 0.1, 2)
        else:
            shade = np.where(inside, SHADES[pattern], 1.0)
        self._shade = cv2.GaussianBlur(shade.astype(np.float32), (0, 0), 0.7)[:, :, None]

    def _paint(self, box, patch, occlusion) -> None:
        super()._paint(box, patch, occlusion)
        y0, y1, x0, x1 = box
        self._under[y0:y1, x0:x1] = cv2.convertScaleAbs(self._under[y0:y1, x0:x1] * self._shade[y0:y1, x0:x1])


def deformed(origin: np.ndarray, shear_px: float = 0.0, twist_px: float = 0.0, spread_px: float = 0.0,
             centre=(160.0, 120.0), sigma: float = 50.0) -> np.ndarray:
    """Marker positions under a Gaussian contact patch (centre `centre`, width `sigma` px): `shear_px`
    along x at the patch centre, `twist_px` of tangential motion at one `sigma` from it (torsion),
    `spread_px` of radial spread there (normal load). Non-uniform, as a firm grasp deforms the skin."""
    rel = (origin - np.asarray(centre)) / sigma
    weight = np.exp(-(rel**2).sum(axis=1) / 2.0)[:, None]
    tangent = np.column_stack([-rel[:, 1], rel[:, 0]])
    return origin + weight * (np.array([shear_px, 0.0]) + twist_px * tangent + spread_px * rel)


class StressBench:
    """Independent stress sequences on a dense, jittered marker layout: strain (shear, torsion),
    objects behind the skin (QR-like texture, dark), lighting gain, blur and noise."""

    def __init__(self, seed: int = 0, pattern: str = "", share: float = 0.0, marker_size: float = 9.0):
        self.origin = dense_layout(seed)
        self.marker_size = marker_size
        self.plain = SyntheticFingerVision(self.origin, marker_size, seed=seed)  # the same scene, no object
        self.camera = PatternedCamera(self.origin, marker_size, seed, share, pattern) if pattern else self.plain

    def calibration(self, n: int = 10) -> list[np.ndarray]:
        """Frames with no contact and no object in view (noise 2)."""
        return [self.plain.render(appearance=CALIBRATION_LOOK).image for _ in range(n)]

    def strain(self, frames: int, look: Appearance, shear_px: float = 0.0, twist_px: float = 0.0,
               spread_px: float = 4.0, ramp_frames: int = 24) -> Sequence:
        """Shear and/or torsion growing smoothly over `ramp_frames` (25 px: at most 1.7 px per frame),
        then held; the calibration frames are clean (noise 2, no object in view)."""
        out = []
        for k in range(frames):
            ramp = 0.5 * (1.0 - np.cos(np.pi * min(1.0, k / ramp_frames)))
            pos = deformed(self.origin, ramp * shear_px, ramp * twist_px, ramp * spread_px)
            out.append(self.camera.render(pos, self.marker_size, appearance=look))
        return Sequence(self.calibration(), out, self.origin)
