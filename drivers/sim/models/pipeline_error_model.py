"""What the real FingerVision pipeline gets wrong, as a compact seeded error model that signals
mode applies to the contact model's exact values, so a skill tuned in signals mode meets the
errors it will meet in pixel mode and on a real sensor.

Measured in pixel mode against the scene's truth by `assembly/bench/perception/error_model_fit.py` (hold,
in_hand_rot, object_track and the first assembly element, both fingers, 7354 ticks; the defaults
below are its fitted model, `pipeline_errors.json` in its output). Re-run it after a change to
`perception/` and copy the new figures here. The model:
- markers: first-order lag `lag_alpha` (the Kalman filter), noise `noise_px` (AR(1) with
  `noise_persistence`; white by default); the losses
  are concentrated on a few markers (texture or the object's edge over them): a share
  `lossy_share` of them, fixed per sensor, is lost on a tick with probability `lossy_rate` (not
  valid; it keeps its last estimate, as in the filter);
- object: missed on a tick with probability `object_miss`; area scaled by `area_scale` (the
  proximity mask sees less than the whole object) with noise `area_noise`; centroid noise
  `centroid_px` (px, 2-D rms) and orientation noise `angle_rad`;
- slip: MOG2 reports image motion over the object, not slip alone, so the reported slip is
  `slip_gain * area * min(motion, slip_saturation)` (motion: px/frame of the object's texture,
  edge, turn and of the markers over it; see `image_motion`), `slip_delay` ticks late, times
  (1 + `slip_noise` * N(0, 1)), plus a floor drawn as `slip_floor` * Exp(1).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import asdict, dataclass

import numpy as np

from perception.state import MarkerField, ObjectInfo
from perception.wrench import wrench_terms

IMAGE_SCALE = 280.0  # px per unit of normalised centroid ((W + H) / 2 of the 320x240 image)
IMAGE_PIXELS = 320 * 240
SLIP_PX_PER_UNIT = 4.0  # rendered object texture speed (px/frame) per unit of the contact model's slip


@dataclass(frozen=True)
class PipelineErrors:
    """Parameters of the error model (defaults: measured, see the module docstring)."""

    noise_px: float = 0.038  # px (the cell's sensor profile sets it: `SensorProfile.noise_sigma_px`)
    noise_persistence: float = 0.0  # lag-1 autocorrelation of the marker noise (AR(1); 0: white)
    lag_alpha: float = 1.0  # measured 0.975: the gated Kalman filter restarts on a real move (no lag modelled)
    lossy_share: float = 0.105  # share of markers the tracker often loses (texture or the object's edge on them)
    lossy_rate: float = 0.37  # how often one of those is lost on a tick
    object_miss: float = 0.0
    area_scale: float = 0.67
    area_noise: float = 0.0043  # share of the image
    centroid_px: float = 1.14
    angle_rad: float = 0.016
    slip_gain: float = 0.43  # slip per (area share * px/frame)
    slip_saturation: float = 1.0  # px/frame
    slip_floor: float = 0.0016
    slip_noise: float = 0.83  # relative
    slip_delay: int = 0  # ticks

    def as_dict(self) -> dict:
        return asdict(self)


def object_radius(area: float) -> float:
    """px radius of a disc covering `area` (share) of the image."""
    return math.sqrt(max(area, 0.0) * IMAGE_PIXELS / math.pi)


def image_motion(prev, contact, prev_markers: np.ndarray, markers: np.ndarray) -> float:
    """px/frame the object shows moving between two FingerContacts: its texture sliding (slip),
    its centroid, its turn (at half its radius), its edge growing or shrinking, and the markers
    moving over it (mean; none when both ticks share one marker array, an unloaded fingertip)."""
    if markers is prev_markers:
        return object_motion(prev, contact, 0.0)
    moved = np.subtract(markers, prev_markers)
    return object_motion(prev, contact, float(np.add.reduce(np.abs(moved, out=moved), axis=None)) / moved.size)


def object_motion(prev, contact, marker_motion: float) -> float:
    """`image_motion` with the markers' mean motion (px/frame) given."""
    obj, last = contact.obj, prev.obj
    motion = SLIP_PX_PER_UNIT * contact.slip + marker_motion
    if obj is last:  # the scene's view of the object did not change: it adds nothing
        return motion
    if obj.present and last.present:
        (dx, dy) = (obj.centroid - last.centroid).tolist()
        radius = object_radius(obj.area)
        motion += math.hypot(dx, dy) * IMAGE_SCALE + abs(obj.orientation - last.orientation) * 0.5 * radius
        motion += abs(radius - object_radius(last.area))
    elif obj.present != last.present:
        motion += object_radius(max(obj.area, last.area))
    return motion


BLOCK = 256  # ticks of random numbers drawn at once: one generator call per block, not several a tick


class ErrorModel:
    """The error model of one sensor, with its state (last estimates, last truth, delayed slip).

    `markers`: the sensor's marker map (origins, image size) and `finger`, for the wrench the
    pipeline's estimator makes of the reported markers (`perception.wrench`, mean, xy_norm)."""

    def __init__(self, errors: PipelineErrors, rng: np.random.Generator, markers: MarkerField, finger: str):
        self.e, self._rng = errors, rng
        self._origin, self._terms = markers.origin, wrench_terms(markers, finger)
        self._estimate: np.ndarray | None = None  # (N, 3) x, y, size the tracker holds, noise-free
        self._truth: np.ndarray | None = None
        self._contact = None
        self._slip: deque[float] = deque([0.0] * errors.slip_delay, maxlen=errors.slip_delay + 1)
        self._tick = BLOCK
        self._last_noise: np.ndarray | None = None  # the last tick's marker noise (persistent noise only)
        from drivers.sim.models.sensor_kernels import observe  # numba: loaded by a sensor, not by an import

        self._observe = observe  # kept: an import statement costs ~1 us a tick
        self._unseen = ObjectInfo()  # the object not seen: one record, handed out unchanged (records are frozen)

    def apply(self, contact, exact: np.ndarray):
        """(positions, sizes, valid, force, torque, object, slip) the pipeline would report for this
        contact and the exact (N, 3) x, y and size of its markers (never changed here: an unloaded
        fingertip's is shared)."""
        if self._estimate is None:
            self._start(exact)
        if self._tick == BLOCK:
            self._draw(len(exact))
        t = self._tick
        self._tick += 1
        first, same = self._truth is None, exact is self._truth
        valid = self._tracked[t]
        n = len(exact)
        position, size, wrench = np.empty((n, 2)), np.empty(n), np.empty(6)
        moved = self._observe(exact, self._truth if not (first or same) else exact, self._estimate, valid,
                              self._noise[t], self.e.lag_alpha, self._origin, self._terms, position, size, wrench)
        force, torque = wrench[:3], wrench[3:]
        obj, slip = self._view(contact, None if first else moved, self._scalars[t], self._centroid[t])
        self._truth = exact
        return position, size, valid if self._any_lost[t] else self._all, force, torque, obj, slip

    def _start(self, exact: np.ndarray) -> None:
        n = len(exact)
        self._lossy = np.flatnonzero(self._rng.random(n) < self.e.lossy_share)  # fixed per sensor
        self._estimate, self._all = np.array(exact, float), np.ones(n, bool)

    def _draw(self, n: int) -> None:
        """The random numbers of the next BLOCK ticks, in one generator call per kind, scaled
        once: marker noise, which lossy markers are lost, and the object and slip noise."""
        e, k = self.e, len(self._lossy)
        normal = self._rng.standard_normal((BLOCK, 3 * n + 5))
        uniform = self._rng.random((BLOCK, k + 2))
        self._noise = e.noise_px * normal[:, :3 * n].reshape(BLOCK, n, 3)  # x, y, size (half as much)
        self._noise[:, :, 2] *= 0.5
        rho = e.noise_persistence
        if rho:  # AR(1) across ticks, carried over from the last block; the same std as white noise
            keep, last = math.sqrt(1.0 - rho * rho), self._last_noise
            for t in range(BLOCK):
                if last is not None:
                    self._noise[t] = rho * last + keep * self._noise[t]
                last = self._noise[t]
            self._last_noise = last
        lost = np.zeros((BLOCK, n), bool)
        lost[:, self._lossy] = uniform[:, :k] < e.lossy_rate
        self._tracked, self._any_lost = ~lost, lost.any(axis=1).tolist()
        z = normal[:, 3 * n:]
        self._centroid = z[:, 2:4] * (e.centroid_px / math.sqrt(2.0) / IMAGE_SCALE)
        # per tick: slip noise, area noise, angle noise, slip floor (Exp(1)), miss draw
        self._scalars = np.column_stack([z[:, 0], e.area_noise * z[:, 1], e.angle_rad * z[:, 4],
                                         -e.slip_floor * np.log1p(-uniform[:, k]), uniform[:, k + 1]]).tolist()
        self._tick = 0

    def _view(self, contact, marker_motion: float | None, scalars: list[float],
              centroid_noise: np.ndarray) -> tuple[ObjectInfo, float]:
        """The object and the slip the pipeline would report (`marker_motion`: the markers' mean
        motion since the last tick, None on the first; `scalars`: this tick's draws, see `_draw`)."""
        e = self.e
        slip_noise, area_noise, angle_noise, floor, miss = scalars
        last, self._contact = self._contact, contact
        motion = 0.0 if marker_motion is None else object_motion(last, contact, marker_motion)
        obj = contact.obj
        area = obj.area if obj.present else 0.0
        self._slip.append(e.slip_gain * area * min(motion, e.slip_saturation))
        expected = self._slip.popleft()
        slip = max(0.0, expected * (1.0 + e.slip_noise * slip_noise)) + floor
        if not obj.present or obj.area <= 0.0 or miss < e.object_miss:
            return self._unseen, slip
        seen = ObjectInfo(True, max(e.area_scale * obj.area + area_noise, 1e-4), obj.centroid + centroid_noise,
                          obj.orientation + angle_noise, obj.cells, obj.motion_cells)
        return seen, slip


def warm_up() -> None:
    """Load the compiled `observe` now (see `perception.wrench.warm_up`)."""
    from drivers.sim.models.sensor_kernels import observe

    exact = np.zeros((1, 3))
    markers = MarkerField(np.zeros((1, 2)))
    observe(exact, exact, exact.copy(), np.ones(1, bool), exact, 1.0, markers.origin, wrench_terms(markers, "left"),
            np.empty((1, 2)), np.empty(1), np.empty(6))
