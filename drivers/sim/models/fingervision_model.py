"""FingerVision contact model: contact loads on a fingertip -> marker displacement field ->
`TactileState` (through the same wrench estimator the real pipeline uses).

Shear moves the markers inside the contact patch along the shear; normal load spreads them
radially and grows their apparent size; torque about the finger normal turns them around the
patch centre. Seeded Gaussian noise is added to marker positions and sizes; with
`pipeline_errors` (the simulated cell's signals mode), the errors of the real pipeline measured in
pixel mode are applied instead (`pipeline_errors.py`: marker lag, noise and dropouts, object
misses and noise, slip as the image motion MOG2 sees, late and noisy).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from drivers.sim.models.pipeline_errors import ErrorModel, PipelineErrors
from perception.state import MarkerField, ObjectInfo, TactileState
from perception.wrench import wrench


@dataclass
class FingerContact:
    """Loads and what the camera sees on one fingertip, in the finger's image axes."""

    normal: float = 0.0  # N, pressing into the gel
    shear: np.ndarray = field(default_factory=lambda: np.zeros(2))  # N, along image x and y
    torque: float = 0.0  # N m about the finger normal
    centre: np.ndarray | None = None  # px, contact patch centre (image centre if None)
    obj: ObjectInfo = field(default_factory=ObjectInfo)
    slip: float = 0.0  # moving object pixels, share of the image


def radial_marker_layout(size=(320, 240), pitch=34.0, radius=105.0) -> np.ndarray:
    """(N, 2) marker origins: a hexagonal grid clipped to the round sensor window."""
    w, h = size
    pts = []
    rows = int(radius // (pitch * 0.866)) + 1
    for r in range(-rows, rows + 1):
        y = r * pitch * 0.866
        off = 0.5 * pitch if r % 2 else 0.0
        for c in range(-int(radius // pitch) - 1, int(radius // pitch) + 2):
            x = c * pitch + off
            if x * x + y * y <= radius * radius:
                pts.append((w / 2 + x, h / 2 + y))
    return np.array(pts, dtype=float)


@dataclass
class SensorModel:
    """Gains from loads to marker motion, and the noise, of one simulated sensor."""

    finger: str
    image_size: tuple[int, int] = (320, 240)
    shear_gain: float = 0.25  # px per N of shear at the patch centre
    normal_gain: float = 0.06  # px of radial spread per N of normal load
    size_gain: float = 0.03  # px of diameter growth per N of normal load
    torque_gain: float = 12.0  # px of tangential motion per N m at the patch rim
    patch_sigma: float = 90.0  # px, width of the contact patch weighting
    marker_size: float = 9.0  # px diameter at rest
    noise_px: float = 0.05  # px, std of marker position noise (without the pipeline error model)
    seed: int = 0
    normal_mode: str = "xy_norm"
    pipeline_errors: bool = False  # apply the measured errors of the real pipeline (signals mode)

    def __post_init__(self):
        self.origin = radial_marker_layout(self.image_size)
        self._origin_size = np.full(len(self.origin), self.marker_size)
        self._valid = np.ones(len(self.origin), bool)
        self._rng = np.random.default_rng(self.seed)
        self._centre = np.array(self.image_size, float) / 2.0
        self._patch_key = None
        self._errors: ErrorModel | None = None

    def _patch(self, centre: np.ndarray):
        """Per-marker patch weight, radial and tangential unit fields for a contact centre."""
        key = (float(centre[0]), float(centre[1]))
        if key != self._patch_key:
            rel = (self.origin - centre) / self.patch_sigma
            weight = np.exp(-(rel**2).sum(axis=1) / 2.0)[:, None]
            self._patch_cache = (weight, weight * rel, weight * np.column_stack([-rel[:, 1], rel[:, 0]]))
            self._patch_key = key
        return self._patch_cache

    def state(self, contact: FingerContact, stamp: float) -> TactileState:
        """Render one `TactileState` from the loads on this fingertip."""
        weight, radial, tangential = self._patch(self._centre if contact.centre is None else contact.centre)
        n = len(self.origin)
        errors = self._error_model() if self.pipeline_errors else None
        noise = self._rng.normal(0.0, self.noise_px, (n, 3)) if self.noise_px and not errors else None
        position = self.origin + noise[:, :2] if noise is not None else self.origin.copy()
        position += weight * (self.shear_gain * np.asarray(contact.shear, float))
        if contact.normal:
            position += (self.normal_gain * contact.normal) * radial
        if contact.torque:
            position += (self.torque_gain * contact.torque) * tangential
        size = self._origin_size + self.size_gain * max(contact.normal, 0.0) * weight[:, 0]
        obj, slip, valid = contact.obj, contact.slip, self._valid
        if errors is not None:
            position, size, valid, obj, slip = errors.apply(contact, position, size)
        elif noise is not None:
            size += 0.5 * noise[:, 2]
        markers = MarkerField(self.origin, position, self._origin_size, size, valid, self.image_size)
        force, torque = wrench(markers, self.finger, self.normal_mode)
        return TactileState(self.finger, stamp, markers, force, torque, obj, slip)

    def _error_model(self) -> ErrorModel:
        if self._errors is None:
            self._errors = ErrorModel(PipelineErrors(), self._rng)
        return self._errors
