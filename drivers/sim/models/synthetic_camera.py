"""Synthetic FingerVision camera: BGR frames rendered from a marker displacement field, with ground
truth, and the pixel-level perception source of the simulated cell.

A frame is a round sensor window (dark housing around it) showing a blurred, fisheye-distorted,
vignetted scene of background clutter, optionally a textured object pressed on the skin (it can
slide: `obj_shift`) and a moving distractor behind it; black markers are drawn on top with
anti-aliased, radially foreshortened discs whose centres are exactly the given positions. Lighting
gain and gradient, dark occluders behind the skin, glare, blur and sensor noise are applied per
frame. Everything random is drawn from the camera's seeded generator.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping

import cv2
import numpy as np

from drivers.clock import SimClock
from drivers.protocols import World
from drivers.sim.models.fingervision_model import SensorModel
from perception.state import FINGERS, ObjectInfo, TactileState

MARKER_GREY = 18.0  # marker core brightness before lighting
HOUSING_GREY = 50.0
OBJECT_BGR = (40.0, 120.0, 235.0)  # bright orange, as the thesis painted its test objects
SKIN_BGR = (120.0, 150.0, 205.0)
SLIP_PX_PER_UNIT = 4.0  # rendered object speed (px/frame) per unit of the contact model's slip


@dataclass(frozen=True)
class Appearance:
    """Per-frame image conditions."""

    noise: float = 2.0  # std of the sensor noise, grey levels (the same on all channels)
    gain: float = 1.0  # global lighting gain
    gradient: float = 0.0  # lighting change across the image, share of the gain (left to right)
    blur: float = 0.0  # Gaussian blur sigma, px
    occlusion: float = 0.0  # share of the window hidden behind a dark object (markers lose contrast)
    glare: float = 0.0  # share of the window washed out by a specular highlight


@dataclass(frozen=True)
class Truth:
    """What a frame shows: marker centres and diameters, which markers are visible, the object."""

    position: np.ndarray  # (N, 2) px
    size: np.ndarray  # (N,) px, equivalent diameter of the rendered (foreshortened) marker
    visible: np.ndarray  # (N,) bool
    object_mask: np.ndarray  # (H, W) bool
    obj: ObjectInfo
    obj_shift: float  # px the object texture has slid along its long axis


@dataclass(frozen=True)
class RenderedFrame:
    image: np.ndarray  # (H, W, 3) uint8 BGR
    truth: Truth


def object_info_from_mask(mask: np.ndarray) -> ObjectInfo:
    """Area share, centroid and orientation of a boolean mask, in the proximity-vision convention."""
    h, w = mask.shape
    m = cv2.moments(mask.astype(np.uint8), binaryImage=True)
    if m["m00"] == 0:
        return ObjectInfo()
    div = (w + h) / 2.0
    centroid = np.array([(m["m10"] / m["m00"] - w / 2.0) / div, (m["m01"] / m["m00"] - h / 2.0) / div])
    angle = 0.5 * np.arctan2(2.0 * m["mu11"], m["mu20"] - m["mu02"])
    return ObjectInfo(True, m["m00"] / float(w * h), centroid, float(angle))


@dataclass
class SyntheticFingerVision:
    """Renders frames of one FingerVision sensor whose markers rest at `origin` (N, 2) px."""

    origin: np.ndarray
    marker_size: float = 9.0  # px diameter at rest, seen frontally
    image_size: tuple[int, int] = (320, 240)
    seed: int = 0
    window_radius: float = 128.0  # px, radius of the round sensor window
    foreshortening: float = 0.35  # radial squash of markers at the window rim
    clutter: int = 14  # background shapes
    _rng: np.random.Generator = field(init=False, repr=False)

    def __post_init__(self):
        self.origin = np.asarray(self.origin, float)
        self._rng = np.random.default_rng(self.seed)
        w, h = self.image_size
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        self._xx, self._yy = xx, yy
        self._centre = np.array([w / 2.0, h / 2.0])
        rr = np.hypot(xx - w / 2.0, yy - h / 2.0)
        self._window = np.clip(self.window_radius + 0.5 - rr, 0.0, 1.0)[:, :, None]  # soft rim
        self._background = self._scene()
        self._occluder_seed = int(self._rng.integers(1 << 31))
        # Object surface: smooth random (non-periodic) texture, mean 1, sampled as the object slides.
        tex = cv2.GaussianBlur(self._rng.standard_normal((256, 256)).astype(np.float32), (0, 0), 2.0)
        self._texture = 1.0 + 0.25 * tex / tex.std()

    # ---- static parts -------------------------------------------------------------------
    def _scene(self) -> np.ndarray:
        """Clutter seen through the lens: shapes, defocus, barrel distortion, vignetting, housing."""
        w, h = self.image_size
        rng = self._rng
        base = np.array([150.0, 185.0, 165.0]) + rng.uniform(-20, 20, 3)
        img = np.empty((h, w, 3), np.float32)
        ramp = (0.85 + 0.3 * self._xx / w)[:, :, None]
        img[:] = base * ramp
        for _ in range(self.clutter):
            colour = rng.uniform(60, 235, 3)
            cx, cy = rng.uniform(0, w), rng.uniform(0, h)
            a, b = rng.uniform(12, 60, 2)
            if rng.random() < 0.5:
                cv2.ellipse(img, (int(cx), int(cy)), (int(a), int(b)), float(rng.uniform(0, 180)), 0, 360,
                            colour.tolist(), -1, cv2.LINE_AA)
            else:
                cv2.rectangle(img, (int(cx - a), int(cy - b)), (int(cx + a), int(cy + b)), colour.tolist(), -1)
        img = cv2.GaussianBlur(img, (0, 0), 2.5)
        rn = np.hypot(self._xx - w / 2.0, self._yy - h / 2.0) / self.window_radius
        k = 0.25  # barrel distortion: a point at normalised radius r shows the scene at r (1 + k r^2)
        scale = 1.0 + k * rn**2
        mapx = (w / 2.0 + (self._xx - w / 2.0) * scale).astype(np.float32)
        mapy = (h / 2.0 + (self._yy - h / 2.0) * scale).astype(np.float32)
        img = cv2.remap(img, mapx, mapy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
        img *= (1.0 - 0.3 * np.clip(rn, 0, 1.2) ** 2)[:, :, None]
        return img * self._window + HOUSING_GREY * (1.0 - self._window)

    def _blob_mask(self, share: float, salt: int) -> np.ndarray:
        """Soft (H, W) mask of a seeded irregular blob covering `share` of the window."""
        if share <= 0:
            return np.zeros(self.image_size[::-1], np.float32)
        rng = np.random.default_rng(self._occluder_seed + salt)
        w, h = self.image_size
        target = share * np.pi * self.window_radius**2
        angle = rng.uniform(0, 2 * np.pi)
        r0 = rng.uniform(0.2, 0.5) * self.window_radius
        c = self._centre + r0 * np.array([np.cos(angle), np.sin(angle)])
        a = np.sqrt(target / np.pi * 1.6)
        b = target / (np.pi * a)
        theta = rng.uniform(0, np.pi)
        dx, dy = self._xx - c[0], self._yy - c[1]
        u = dx * np.cos(theta) + dy * np.sin(theta)
        v = -dx * np.sin(theta) + dy * np.cos(theta)
        rho = np.sqrt((u / a) ** 2 + (v / b) ** 2)
        return np.clip((1.0 - rho) * min(a, b) / 2.0 + 0.5, 0.0, 1.0).astype(np.float32) * self._window[:, :, 0]

    # ---- per-frame parts ----------------------------------------------------------------
    def _object(self, obj: ObjectInfo, shift: float) -> tuple[np.ndarray, np.ndarray]:
        """(soft mask (H, W), textured colour (H, W, 3)) of a rectangle with the object's area and pose."""
        w, h = self.image_size
        div = (w + h) / 2.0
        c = self._centre + np.asarray(obj.centroid, float) * div
        area = max(obj.area, 1e-4) * w * h
        length = np.sqrt(area * 1.6)
        width = area / length
        th = obj.orientation
        dx, dy = self._xx - c[0], self._yy - c[1]
        u = dx * np.cos(th) + dy * np.sin(th)
        v = -dx * np.sin(th) + dy * np.cos(th)
        soft = np.clip(np.minimum(length / 2 - np.abs(u), width / 2 - np.abs(v)) + 0.5, 0.0, 1.0)
        texture = cv2.remap(self._texture, (u - shift + 128.0).astype(np.float32),
                            (v + 128.0).astype(np.float32), cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
        colour = texture[:, :, None] * np.asarray(OBJECT_BGR, np.float32)
        return soft.astype(np.float32), colour.astype(np.float32)

    def _markers(self, img: np.ndarray, position: np.ndarray, size: np.ndarray) -> np.ndarray:
        """Draw anti-aliased marker discs in place; returns their equivalent diameters."""
        h, w = img.shape[:2]
        rel = position - self._centre
        rho = np.linalg.norm(rel, axis=1)
        radial = np.where(rho[:, None] > 1e-6, rel / np.maximum(rho, 1e-6)[:, None], [1.0, 0.0])
        a_t = size / 2.0
        a_r = a_t * (1.0 - self.foreshortening * np.clip(rho / self.window_radius, 0, 1) ** 2)
        half = int(np.ceil(a_t.max(initial=1.0) + 2))
        off = np.arange(-half, half + 1)
        ix = np.floor(position[:, 0]).astype(int)
        iy = np.floor(position[:, 1]).astype(int)
        gx = ix[:, None, None] + off[None, None, :]
        gy = iy[:, None, None] + off[None, :, None]
        dx = gx - position[:, 0, None, None]
        dy = gy - position[:, 1, None, None]
        u = dx * radial[:, 0, None, None] + dy * radial[:, 1, None, None]
        v = -dx * radial[:, 1, None, None] + dy * radial[:, 0, None, None]
        rn = np.sqrt((u / a_r[:, None, None]) ** 2 + (v / a_t[:, None, None]) ** 2)
        mean_r = np.sqrt(a_r * a_t)[:, None, None]
        cover = np.clip(0.5 - (rn - 1.0) * mean_r, 0.0, 1.0)  # ~1 px linear edge: area coverage
        inside = (gx >= 0) & (gx < w) & (gy >= 0) & (gy < h)
        cover = np.where(inside, cover, 0.0)
        gx, gy = np.clip(gx, 0, w - 1), np.clip(gy, 0, h - 1)
        c = cover[..., None].astype(np.float32)
        img[gy, gx] = img[gy, gx] * (1.0 - c) + MARKER_GREY * c
        return 2.0 * np.sqrt(a_r * a_t)

    def render(self, position: np.ndarray | None = None, size: np.ndarray | float | None = None,
               obj: ObjectInfo | None = None, obj_shift: float = 0.0,
               appearance: Appearance = Appearance(), distractor: np.ndarray | None = None) -> RenderedFrame:
        """One frame with markers at `position` (default: origins), sizes in px diameter."""
        position = self.origin if position is None else np.asarray(position, float)
        if position.shape != self.origin.shape:
            raise ValueError(f"positions have shape {position.shape}, the sensor has {self.origin.shape}")
        size = np.broadcast_to(np.asarray(self.marker_size if size is None else size, float),
                               (len(position),))
        img = self._background.copy()
        if distractor is not None:  # something moving behind the object, e.g. a hand
            cv2.ellipse(img, (int(distractor[0]), int(distractor[1])), (26, 38), 20.0, 0, 360,
                        SKIN_BGR, -1, cv2.LINE_AA)
            img = img * self._window + HOUSING_GREY * (1.0 - self._window)
        mask = np.zeros(self.image_size[::-1], bool)
        truth_obj = ObjectInfo()
        if obj is not None and obj.present and obj.area > 0:
            soft, colour = self._object(obj, obj_shift)
            soft *= self._window[:, :, 0]
            img += soft[:, :, None] * (colour - img)
            mask = soft >= 0.5
            truth_obj = object_info_from_mask(mask)
        dark = self._blob_mask(appearance.occlusion, 1)
        if appearance.occlusion > 0:
            img *= (1.0 - 0.9 * dark)[:, :, None]
        diameters = self._markers(img, position, size)
        if appearance.gain != 1.0 or appearance.gradient:
            light = appearance.gain * (1.0 + appearance.gradient * (self._xx / self.image_size[0] - 0.5))
            img *= light[:, :, None]
        glare = self._blob_mask(appearance.glare, 2)
        if appearance.glare > 0:
            img += (glare * 1.2)[:, :, None] * (255.0 - img)
        if appearance.blur > 0:
            img = cv2.GaussianBlur(img, (0, 0), appearance.blur)
        if appearance.noise > 0:
            img += (self._rng.standard_normal(img.shape[:2], np.float32) * appearance.noise)[:, :, None]
        image = np.clip(img + 0.5, 0, 255).astype(np.uint8)
        visible = self._visible(position, dark, glare)
        return RenderedFrame(image, Truth(position.copy(), diameters, visible, mask, truth_obj, obj_shift))

    def _visible(self, position: np.ndarray, dark: np.ndarray, glare: np.ndarray) -> np.ndarray:
        """Markers wholly inside the image and the window and clear of occluders and glare."""
        w, h = self.image_size
        inside = (position[:, 0] >= 0) & (position[:, 0] < w) & (position[:, 1] >= 0) & (position[:, 1] < h)
        rim = np.linalg.norm(position - self._centre, axis=1) < self.window_radius - 4
        hidden = np.maximum(dark, glare)
        angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
        ring = np.concatenate([[[0.0, 0.0]], (self.marker_size / 2 + 1) * np.column_stack(
            [np.cos(angles), np.sin(angles)])])  # the centre and a circle just outside the marker
        pts = position[:, None, :] + ring[None, :, :]
        ix = np.clip(np.rint(pts[..., 0]).astype(int), 0, w - 1)
        iy = np.clip(np.rint(pts[..., 1]).astype(int), 0, h - 1)
        return inside & rim & (hidden[iy, ix].max(axis=1) < 0.1)


def pixel_level_sense(world: World, sensors: Mapping[str, SensorModel], clock: SimClock, seed: int,
                      preset: str = "fast") -> Callable[[], dict[str, TactileState]]:
    """Perception source of the simulated cell that renders each finger's frame and runs the real
    FingerVision pipeline on it (calibrated at start on frames with no contact)."""
    from perception.config import load_config
    from perception.fingervision import (
        FingerVision,  # the real pipeline, as on the robot
    )

    fps = 1.0 / clock.period
    cameras, pipelines = {}, {}
    for i, finger in enumerate(FINGERS):
        sensor = sensors[finger]
        camera = SyntheticFingerVision(sensor.origin, sensor.marker_size, tuple(sensor.image_size),
                                       seed=seed * 2 + i)
        pipeline = FingerVision(load_config(preset, camera_fps=fps), finger)
        n = pipeline.config.calibration.n_frames
        pipeline.calibrate([camera.render().image for _ in range(n)])
        # The object colour model, marked on three frames of a known object (the original's hand edit).
        for _ in range(3):
            sample = camera.render(obj=ObjectInfo(True, 0.3, np.zeros(2), 0.0))
            pipeline.proximity.add_object(sample.image, sample.truth.object_mask)
        cameras[finger], pipelines[finger] = camera, pipeline
    shift = {finger: 0.0 for finger in FINGERS}

    def sense() -> dict[str, TactileState]:
        contacts = world.contacts()
        now = clock.now()
        states = {}
        for finger in FINGERS:
            contact = contacts[finger]
            truth = sensors[finger].state(contact, now).markers
            shift[finger] += SLIP_PX_PER_UNIT * contact.slip
            frame = cameras[finger].render(truth.position, truth.size, contact.obj, shift[finger])
            states[finger] = pipelines[finger].process(frame.image, now)
        return states

    return sense
