"""Synthetic FingerVision camera: BGR frames rendered from a marker displacement field, with ground
truth, and the pixel-level perception source of the simulated cell.

A frame is a round sensor window (dark housing around it) showing a blurred, fisheye-distorted,
vignetted scene of background clutter, optionally a textured object pressed on the skin (it can
slide: `obj_shift`) and a moving distractor behind it; black markers are drawn on top as
anti-aliased, radially foreshortened discs whose centres are the given positions plus the sensor's
rest jitter (`jitter_px`: seeded AR(1) wander, so the tracker measures the profile's rest jitter, see
`drawn_jitter`). Lighting gain and gradient, dark occluders behind the skin, glare, blur and sensor
noise are applied per frame. Everything random is drawn from the camera's seeded generators.

Only what changed is drawn again (dirty rectangles): the clutter is drawn once; the layer beneath
the markers (clutter, distractor, object, occluder) is redrawn on the object's bounding box when the
object moves; when a marker moves (with rest jitter: on every frame) the markers are drawn again on a
copy of that layer (one copy of 230 kB: quicker than restoring their old patches row by row); the
lighting (gain, gradient, colour cast, glare: the costliest part of a frame drawn whole) is applied to
the rectangles that changed only (the layer's redrawn boxes and the markers' old and new patches,
`layer_kernels`), the lit frame kept between frames. A frame so drawn equals one drawn from scratch to the bit
(`redraw_all` draws every frame from scratch: the reference the tests compare against). A frame where
nothing moved more than `TOLERANCE_PX` reuses the last noise-free image (its truth is what was
drawn). The sensor noise is fresh on every frame (`noise_bank`). A blurred look is drawn whole.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import cv2
import numpy as np

from drivers.clock import SimClock
from drivers.protocols import World
from drivers.sim.models.appearance import DEFAULT_LOOK, Look
from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.models.layer_kernels import light_float, light_rects
from drivers.sim.models.marker_patches import MarkerPainter
from drivers.sim.models.noise_bank import NoiseBank
from drivers.sim.models.object_layer import OBJECT_BGR, ObjectLayer, ObjectPatch, Placement, object_info_from_mask
from drivers.sim.models.pipeline_error_model import SLIP_PX_PER_UNIT
from drivers.sim.models.skin import Skin
from perception.sensor_profile import SensorProfile
from perception.state import FINGERS, ObjectInfo, TactileState

HOUSING_GREY = 50.0
SKIN_BGR = (120.0, 150.0, 205.0)
TOLERANCE_PX = 0.01  # a marker or object edge moving less than this keeps the last drawing
# How the pipeline's marker tracker, without its Kalman filter (as the blob tracker of the real logs the
# profile's rest jitter comes from), sees the drawn markers of a still skin (measured on 2 x 300 frames,
# tests/perception/test_fv_sim_camera.py::test_pixel_mode_rest_jitter_is_the_profiles_through_the_tracker):
TRACKED_SHARE = 0.86  # of a marker's drawn sub-pixel wander (the local threshold and pixel grid keep the rest)
IMAGE_NOISE_PX = 0.0103  # px per axis of its own, from the 2-grey-level image noise on a still drawing


def drawn_jitter(profile: SensorProfile) -> float:
    """Per-axis std (px) of the wander to draw the markers with, so that the tracker measures the
    profile's rest jitter (`rest_jitter_px`, median frame-to-frame step) on top of the image noise: the
    steps' variance 2 sigma^2 (1 - rho) is the drawn part's (TRACKED_SHARE sigma_d)^2 2 (1 - rho) plus
    the image noise's 2 IMAGE_NOISE_PX^2 (white)."""
    keep = 1.0 - profile.jitter_persistence
    wanted = profile.noise_sigma_px**2 * keep - IMAGE_NOISE_PX**2
    return math.sqrt(max(wanted, 0.0) / keep) / TRACKED_SHARE


@dataclass(frozen=True)
class Appearance:
    """Per-frame image conditions."""

    noise: float = 2.0  # std of the sensor noise, grey levels (the same on all channels)
    gain: float = 1.0  # global lighting gain
    gradient: float = 0.0  # lighting change across the image, share of the gain (left to right)
    blur: float = 0.0  # Gaussian blur sigma, px
    occlusion: float = 0.0  # share of the window hidden behind a dark object (markers lose contrast)
    glare: float = 0.0  # share of the window washed out by a specular highlight
    cast: tuple[float, float, float] = (1.0, 1.0, 1.0)  # B, G, R gains of the light (a colour cast)

    @property
    def plain(self) -> bool:
        """No lighting change, glare or blur: the noise-free image is the drawn layers as they are."""
        return self.gain == 1.0 and not self.gradient and not self.glare and not self.blur and self.white

    @property
    def white(self) -> bool:
        """No colour cast."""
        return self.cast == (1.0, 1.0, 1.0)

    @property
    def lighting(self) -> tuple:
        """What the lighting of the noise-free frame depends on."""
        return self.gain, self.gradient, self.glare, self.blur, self.cast


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


@dataclass(frozen=True)
class _Under:
    """What the layer beneath the markers shows."""

    distractor: tuple[int, int] | None
    place: Placement | None
    occlusion: float


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
    jitter_px: float = 0.0  # per-axis std of the markers' wander about the positions given to `render`, px
    jitter_persistence: float = 0.0  # lag-1 autocorrelation of that wander from frame to frame (AR(1))
    background_tint: tuple[float, float, float] = (1.0, 1.0, 1.0)  # B, G, R gains of the clutter behind the skin
    object_bgr: tuple[float, float, float] = OBJECT_BGR  # the object's colour
    redraw_all: bool = False  # draw every frame from scratch (the dirty rectangles' reference)
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
        self._object = ObjectLayer(self._rng, self._window[:, :, 0], self.object_bgr)
        self._noise_seed = int(self._rng.integers(1 << 31))
        self._painter = MarkerPainter(self.image_size, self._centre, self.window_radius, self.foreshortening)
        self._masks: dict[tuple[float, int], np.ndarray] = {}
        self._noise: dict[float, NoiseBank] = {}
        # The cached layers and what they show.
        self._clutter = cv2.convertScaleAbs(self._background)  # >= 0: a rounding, saturating cast
        self._base, self._base_distractor = self._clutter, None  # clutter (+ distractor), uint8
        self._under = np.empty((h, w, 3), np.uint8)  # beneath the markers, uint8
        self._shown: _Under | None = None  # what `_under` shows
        self._object_box: tuple[int, int, int, int] | None = None
        self._object_truth = (np.zeros((h, w), bool), ObjectInfo())
        self._marked = np.empty((h, w, 3), np.uint8)  # the layer beneath with the markers on it, unlit
        self._clean = self._marked  # the noise-free frame: `_marked` lit (the same array under a plain look)
        self._lighting: tuple | None = None  # the look `_clean` is lit with (None: nothing drawn yet)
        self._dirty: list[tuple[int, int, int, int]] = []  # rectangles of `_under` redrawn since then
        self._boxes = np.zeros((0, 4), np.int64)  # the markers' patches on `_marked`
        self._lights: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}  # lighting -> its arrays
        self._hidden: dict[tuple[float, float], tuple[np.ndarray, np.ndarray]] = {}  # (occlusion, glare) -> masks
        self._drawn_position = np.full_like(self.origin, np.nan)  # the markers as last drawn
        self._drawn_size = np.full(len(self.origin), np.nan)
        self._diameters = np.zeros(len(self.origin))
        self._squash = np.ones(len(self.origin))
        self._seen = np.ones(len(self.origin), bool)  # which drawn markers are visible
        # The markers' rest jitter: its own generator, so the scene drawn above stays as it was.
        self._jitter_rng = np.random.default_rng([self.seed, 0x4A17])
        self._wander: np.ndarray | None = None  # drawn from the stationary distribution on the first frame

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
        if self.background_tint != (1.0, 1.0, 1.0):
            img *= np.asarray(self.background_tint, np.float32)
        return img * self._window + HOUSING_GREY * (1.0 - self._window)

    def _blob_mask(self, share: float, salt: int) -> np.ndarray:
        """Soft (H, W) mask of a seeded irregular blob covering `share` of the window (cached)."""
        key = (share, salt)
        if key not in self._masks:
            self._masks[key] = self._draw_blob(share, salt)
        return self._masks[key]

    def _draw_blob(self, share: float, salt: int) -> np.ndarray:
        if share <= 0:
            return np.zeros(self.image_size[::-1], np.float32)
        rng = np.random.default_rng(self._occluder_seed + salt)
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

    # ---- the layer beneath the markers ----------------------------------------------------
    def _update_under(self, obj: ObjectInfo | None, shift: float, occlusion: float,
                      distractor: np.ndarray | None) -> None:
        """Redraw what changed of clutter, distractor, object and occluder."""
        place = self._object.place(obj, shift) if obj is not None and obj.present and obj.area > 0 else None
        spot = None if distractor is None else (int(distractor[0]), int(distractor[1]))
        last, now = self._shown, _Under(spot, place, occlusion)
        if last is not None and spot == last.distractor and occlusion == last.occlusion:
            if place is None and last.place is None:
                return
            if place is not None and not place.moved(last.place, TOLERANCE_PX):
                return
            if self._object_box is not None:
                self._paint(self._object_box, None, occlusion)  # the object's old box, without it
        else:
            self._set_base(spot)
            self._paint((0, self.image_size[1], 0, self.image_size[0]), None, occlusion)
        self._shown = now
        self._object_box, self._object_truth = None, (np.zeros(self.image_size[::-1], bool), ObjectInfo())
        patch = self._object.draw(place) if place is not None else None
        if patch is not None:
            self._paint(patch.box, patch, occlusion)
            y0, y1, x0, x1 = self._object_box = patch.box
            mask = np.zeros(self.image_size[::-1], bool)
            inside = mask[y0:y1, x0:x1]
            np.greater_equal(patch.soft, 0.5, out=inside)
            mask.flags.writeable = False  # shared by the frames that show this object
            self._object_truth = (mask, object_info_from_mask(inside, (x0, y0), self.image_size))

    def _set_base(self, spot: tuple[int, int] | None) -> None:
        """Clutter, with the distractor (something moving behind the object, e.g. a hand) at `spot`."""
        if spot == self._base_distractor:
            return
        self._base_distractor = spot
        if spot is None:
            self._base = self._clutter
            return
        img = self._background.copy()
        cv2.ellipse(img, spot, (26, 38), 20.0, 0, 360, SKIN_BGR, -1, cv2.LINE_AA)
        self._base = cv2.convertScaleAbs(img * self._window + HOUSING_GREY * (1.0 - self._window))

    def _paint(self, box: tuple[int, int, int, int], patch: ObjectPatch | None, occlusion: float) -> None:
        """Redraw the layer beneath the markers on `box`: base, the object patch (if any), occluder."""
        y0, y1, x0, x1 = box
        region = self._base[y0:y1, x0:x1]
        if patch is not None:
            region = cv2.blendLinear(patch.colour, region, patch.soft, 1.0 - patch.soft)
        if occlusion > 0:
            shade = 1.0 - 0.9 * self._blob_mask(occlusion, 1)[y0:y1, x0:x1]
            region = cv2.convertScaleAbs(region * shade[:, :, None])
        self._under[y0:y1, x0:x1] = region
        self._dirty.append(box)

    # ---- markers and the noise-free frame ---------------------------------------------------
    def _clean_frame(self, position: np.ndarray, size: np.ndarray, look: Appearance) -> np.ndarray:
        """The noise-free frame (uint8): markers over the layer beneath, lighting, glare, blur; drawn
        again only where the layer beneath or a marker changed (see the module docstring)."""
        moved = not (np.abs(position - self._drawn_position).max(initial=0.0) <= TOLERANCE_PX
                     and np.abs(size - self._drawn_size).max(initial=0.0) <= TOLERANCE_PX)
        if moved:
            self._drawn_position, self._drawn_size = position.copy(), size.copy()
            self._squash = self._painter.squash(position)
            self._diameters = size * self._squash  # equivalent diameters of the squashed discs
        lighting = look.lighting
        if not moved and not self._dirty and lighting == self._lighting:
            return self._clean
        self._seen = self._visible(self._drawn_position, look)
        np.copyto(self._marked, self._under)  # one copy: quicker than the changed rectangles' rows
        boxes = self._painter.paint(self._marked, self._drawn_position, self._drawn_size, self._squash)
        if look.plain:
            self._clean = self._marked
        elif look.blur > 0:
            self._clean = self._blurred(look)
        else:
            if self._clean is self._marked:
                self._clean = np.empty_like(self._marked)
            light, cast, glare = self._light(look)
            h, w = self._marked.shape[:2]
            if self.redraw_all or lighting != self._lighting:
                rects = np.array([[0, h, 0, w]])
            else:  # where the layer beneath was redrawn; a marker's patch of the last frame is lit again
                # with its new one (mostly the same box)
                kept = (self._boxes == boxes).all(axis=1) if len(self._boxes) == len(boxes) else False
                rects = np.concatenate([np.array(self._dirty, np.int64).reshape(-1, 4), self._boxes[~kept], boxes])
            light_rects(self._marked, self._clean, rects, light, cast, glare)
        self._boxes, self._dirty, self._lighting = boxes, [], lighting
        return self._clean

    def _light(self, look: Appearance) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(light (H, W), cast (3,), 1.2 x glare mask (H, W)), float32, of a look's lighting (cached)."""
        if look.lighting not in self._lights:
            light = look.gain * (1.0 + look.gradient * (self._xx / self.image_size[0] - 0.5))
            glare = self._blob_mask(look.glare, 2) * 1.2 if look.glare > 0 else np.zeros_like(light)
            self._lights[look.lighting] = (np.ascontiguousarray(light, np.float32),
                                           np.asarray(look.cast, np.float32), np.asarray(glare, np.float32))
        return self._lights[look.lighting]

    def _blurred(self, look: Appearance) -> np.ndarray:
        """The whole noise-free frame lit, blurred, rounded."""
        img = np.empty(self._marked.shape, np.float32)
        light_float(self._marked, img, *self._light(look))
        return cv2.convertScaleAbs(cv2.GaussianBlur(img, (0, 0), look.blur))  # >= 0: a rounding, saturating cast

    def render(self, position: np.ndarray | None = None, size: np.ndarray | float | None = None,
               obj: ObjectInfo | None = None, obj_shift: float = 0.0,
               appearance: Appearance = Appearance(), distractor: np.ndarray | None = None) -> RenderedFrame:
        """One frame with markers at `position` (default: origins), sizes in px diameter."""
        position = self.origin if position is None else np.asarray(position, float)
        if position.shape != self.origin.shape:
            raise ValueError(f"positions have shape {position.shape}, the sensor has {self.origin.shape}")
        size = np.asarray(self.marker_size if size is None else size, float)
        if size.shape != (len(position),):
            size = np.full(len(position), size)
        if self.jitter_px > 0.0:
            position = position + self._jitter()
        self._update_under(obj, obj_shift, appearance.occlusion, distractor)
        clean = self._clean_frame(position, size, appearance)
        image = self._noise_bank(appearance.noise).add(clean) if appearance.noise > 0 else clean.copy()
        mask, truth_obj = self._object_truth
        place = self._shown.place
        return RenderedFrame(image, Truth(self._drawn_position.copy(), self._diameters, self._seen, mask,
                                          truth_obj, place.shift if place is not None else obj_shift))

    def _jitter(self) -> np.ndarray:
        """(N, 2) px the markers wander from where the contact puts them on this frame: seeded AR(1)
        noise of per-axis std `jitter_px` and persistence `jitter_persistence` (a real sensor's rest
        jitter: camera and compression noise, skin micro-motion, beyond the image noise drawn here)."""
        fresh = self._jitter_rng.standard_normal(self.origin.shape) * self.jitter_px
        rho = self.jitter_persistence
        self._wander = fresh if self._wander is None else rho * self._wander + math.sqrt(1.0 - rho * rho) * fresh
        return self._wander

    def _hiding(self, occlusion: float, glare: float) -> tuple[np.ndarray, np.ndarray]:
        """(what hides a marker (H, W): the occluder's and the glare's masks, the larger; the points
        (9, 2) px about a marker's centre where it is looked up: the centre and a circle just outside
        the marker), cached for the look."""
        key = (occlusion, glare)
        if key not in self._hidden:
            angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
            ring = np.concatenate([[[0.0, 0.0]], (self.marker_size / 2 + 1) * np.column_stack(
                [np.cos(angles), np.sin(angles)])])
            self._hidden[key] = (np.maximum(self._blob_mask(occlusion, 1), self._blob_mask(glare, 2)), ring)
        return self._hidden[key]

    def _noise_bank(self, std: float) -> NoiseBank:
        if std not in self._noise:
            self._noise[std] = NoiseBank(std, self.image_size, self._noise_seed + len(self._noise))
        return self._noise[std]

    def _visible(self, position: np.ndarray, look: Appearance) -> np.ndarray:
        """Markers wholly inside the image and the window and clear of occluders and glare."""
        w, h = self.image_size
        inside = (position[:, 0] >= 0) & (position[:, 0] < w) & (position[:, 1] >= 0) & (position[:, 1] < h)
        rim = np.linalg.norm(position - self._centre, axis=1) < self.window_radius - 4
        if look.occlusion <= 0 and look.glare <= 0:
            return inside & rim
        hidden, ring = self._hiding(look.occlusion, look.glare)
        pts = position[:, None, :] + ring[None, :, :]
        ix = np.clip(np.rint(pts[..., 0]).astype(int), 0, w - 1)
        iy = np.clip(np.rint(pts[..., 1]).astype(int), 0, h - 1)
        return inside & rim & (hidden[iy, ix].max(axis=1) < 0.1)


@dataclass(frozen=True)
class FingerRig:
    """What one fingertip's frames need in pixel mode (picklable: a worker process builds its own rig)."""

    finger: str
    origin: np.ndarray  # (N, 2) px, the markers at rest
    marker_size: float
    image_size: tuple[int, int]
    seed: int  # the camera's
    preset: str  # the pipeline configuration
    fps: float
    jitter_px: float = 0.0  # per-axis std of the drawn markers' rest wander (`drawn_jitter`)
    jitter_persistence: float = 0.0  # its lag-1 autocorrelation
    look: Look = DEFAULT_LOOK  # lighting, background and object colour


class PixelFinger:
    """One fingertip in pixel mode: its synthetic camera and the real FingerVision pipeline, calibrated
    at start on frames with no contact, then given a colour model of a known object."""

    def __init__(self, rig: FingerRig):
        from perception.config import load_config
        from perception.fingervision import FingerVision  # the real pipeline, as on the robot

        # Small frames, one at a time: OpenCV's thread pool costs more than it gains on 320x240 images
        # (10-20 % more CPU time per pixel-mode tick with two threads on two cores).
        cv2.setNumThreads(1)
        look = rig.look
        self.camera = SyntheticFingerVision(rig.origin, rig.marker_size, tuple(rig.image_size), seed=rig.seed,
                                            clutter=look.background_clutter, jitter_px=rig.jitter_px,
                                            jitter_persistence=rig.jitter_persistence,
                                            background_tint=look.background_tint, object_bgr=look.object_bgr)
        self.appearance = Appearance(gain=look.brightness, gradient=look.gradient, glare=look.glare,
                                     cast=look.colour_cast)
        self.pipeline = FingerVision(load_config(rig.preset, camera_fps=rig.fps), rig.finger)
        n = self.pipeline.config.calibration.n_frames
        self.pipeline.calibrate([self.camera.render(appearance=self.appearance).image for _ in range(n)])
        # The object colour model, marked on three frames of a known object (the original's hand edit).
        for _ in range(3):
            sample = self.camera.render(obj=ObjectInfo(True, 0.3, np.zeros(2), 0.0), appearance=self.appearance)
            self.pipeline.proximity.add_object(sample.image, sample.truth.object_mask)

    def process(self, position: np.ndarray, size: np.ndarray, obj: ObjectInfo | None, shift: float,
                stamp: float) -> tuple[TactileState, np.ndarray]:
        """The pipeline's state of the frame showing markers at `position` and the object slid by `shift`
        px, and that frame."""
        image = self.camera.render(position, size, obj, shift, self.appearance).image
        return self.pipeline.process(image, stamp), image


def finger_rigs(sensors: Mapping[str, SensorModel], clock: SimClock, seed: int, preset: str,
                look: Look = DEFAULT_LOOK) -> dict[str, FingerRig]:
    """Each finger's rig; camera seeds follow the sensor models' (`seed * 2 + i`); the markers are drawn
    with the rest jitter of the sensor's profile (`drawn_jitter`), the scene with the cell's `look`."""
    return {finger: FingerRig(finger, sensors[finger].origin, sensors[finger].marker_size,
                              tuple(sensors[finger].image_size), seed * 2 + i, preset, 1.0 / clock.period,
                              drawn_jitter(sensors[finger].profile), sensors[finger].profile.jitter_persistence,
                              look)
            for i, finger in enumerate(FINGERS)}


def pixel_level_sense(world: World, sensors: Mapping[str, SensorModel], clock: SimClock, seed: int,
                      preset: str = "fast", workers: bool | None = None,
                      look: Look = DEFAULT_LOOK) -> Callable[[], dict[str, TactileState]]:
    """Perception source of the simulated cell that renders each finger's frame and runs the real
    FingerVision pipeline on it (calibrated at start on frames with no contact).

    The markers are drawn where the contact model puts them without its position noise, plus the
    rest jitter of the sensor's profile (the wander a real sensor's camera, compression and skin add):
    the tracker measures the profile's rest jitter and the pipeline's Kalman filter smooths it, as on
    a real sensor. With `workers` (default: when
    the machine has two cores or more) the fingers are processed at the same time, as a real rig
    processes each camera on its own (`pixel_workers`); the states are the same either way. The
    source's `close()` stops the workers. `look`: the cameras' lighting, background and object colour
    (`drivers.sim.models.appearance`)."""
    from drivers.sim.models.pixel_workers import WORKER_FINGERS, FingerWorkers, parallel_by_default

    rigs = finger_rigs(sensors, clock, seed, preset, look)
    models = {finger: dataclasses.replace(sensors[finger], noise_px=0.0) for finger in FINGERS}
    fields = {finger: _field_of(models[finger]) for finger in FINGERS}
    shift = {finger: 0.0 for finger in FINGERS}
    parallel = parallel_by_default() if workers is None else workers
    fingers = FingerWorkers(PixelFinger, rigs, WORKER_FINGERS if parallel else ())
    skins = {finger: Skin(sensors[finger].profile) for finger in FINGERS}  # as in signals mode

    def sense() -> dict[str, TactileState]:
        contacts = world.contacts()
        now = clock.now()
        frames = {}
        for finger in FINGERS:
            contact = skins[finger].feel(contacts[finger], now)
            position, size = fields[finger](contact)
            shift[finger] += SLIP_PX_PER_UNIT * contact.slip
            frames[finger] = (position, size, contact.obj, shift[finger], now)
        return fingers.process(frames)

    sense.frames = fingers.frames  # for the run's recording
    sense.close = fingers.close
    sense.processes = fingers.processes  # finger -> worker process (empty in-process)
    return sense


def _field_of(model: SensorModel) -> Callable[[FingerContact], tuple[np.ndarray, np.ndarray]]:
    """Marker positions and sizes of a noise-free contact model, computed again only when the
    loads on the fingertip change."""
    last: list = [None, None]

    def field(contact: FingerContact) -> tuple[np.ndarray, np.ndarray]:
        centre = None if contact.centre is None else tuple(np.asarray(contact.centre, float).tolist())
        loads = (float(contact.normal), *np.asarray(contact.shear, float).tolist(), float(contact.torque), centre)
        if loads != last[0]:
            markers = model.state(contact, 0.0).markers
            last[:] = [loads, (markers.position, markers.size)]
        return last[1]

    return field
