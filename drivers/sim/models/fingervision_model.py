"""FingerVision contact model: contact loads on a fingertip -> marker displacement field ->
`TactileState` (through the same wrench estimator the real pipeline uses).

Shear moves the markers inside the contact patch along the shear; normal load spreads them
radially and grows their apparent size; torque about the finger normal turns them around the
patch centre. The gains, marker size and spacing, rest jitter and lost-marker figures come from
the sensor's profile (`perception.sensor_profile`, measured on real sensors): the contact model is
scaled so the markers' mean motion per newton is the profile's. Seeded Gaussian noise is added to
marker positions and sizes; with
`pipeline_errors` (the simulated cell's signals mode), the errors of the real pipeline measured in
pixel mode are applied instead (`pipeline_error_model.py`: marker lag, noise and dropouts, object
misses and noise, slip as the image motion MOG2 sees, late and noisy).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from drivers.sim.models import pipeline_error_model
from drivers.sim.models.pipeline_error_model import ErrorModel, PipelineErrors
from perception.sensor_profile import SensorProfile, default_profile
from perception.state import MarkerField, ObjectInfo, TactileState
from perception.wrench import warm_up, wrench


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


def layout_of(profile: SensorProfile) -> np.ndarray:
    """(N, 2) marker origins of a profile: its spacing, within its field radius."""
    return radial_marker_layout(profile.image_size, profile.marker_spacing_px, profile.marker_field_radius_px)


def patch_weights(origin: np.ndarray, centre: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """(weights, rel): how much a contact at `centre` moves each marker (Gaussian of width `sigma`), and
    each marker's offset from it in units of `sigma`."""
    rel = (origin - centre) / sigma
    return np.exp(-(rel**2).sum(axis=1) / 2.0), rel


@dataclass
class SensorModel:
    """One simulated sensor: loads to marker motion with the gains of its `profile`, and its noise."""

    finger: str
    profile: SensorProfile = field(default_factory=default_profile)
    noise_px: float | None = None  # px, std of marker position noise without the pipeline error model (None: profile's)
    seed: int = 0
    normal_mode: str = "xy_norm"
    pipeline_errors: bool = False  # apply the measured errors of the real pipeline (signals mode)

    def __post_init__(self):
        p = self.profile
        self.image_size = p.image_size
        self.marker_size = p.marker_diameter_px
        self.patch_sigma = p.contact_patch_px
        self.origin = layout_of(p)
        n = len(self.origin)
        self._centre = np.array(self.image_size, float) / 2.0
        # Internal gains so a centred contact moves the markers by the profile's mean px per newton.
        weight, rel = patch_weights(self.origin, self._centre, self.patch_sigma)
        spread = float(np.mean(weight * np.hypot(rel[:, 0], rel[:, 1])))
        self.shear_gain = p.shear_px_per_n / float(np.mean(weight))  # px per N of shear at the patch centre
        self.normal_gain = p.normal_px_per_n / spread  # px of radial spread per N (times weight x rel)
        self.size_gain = p.size_px_per_n  # px of diameter growth per N of normal load at the centre
        self.torque_gain = p.torque_px_per_nm / spread  # px of tangential motion per N m at one patch width
        noise = p.noise_sigma_px if self.noise_px is None else self.noise_px
        self._origin_size = np.full(n, self.marker_size)
        self._rest = np.column_stack([self.origin, self._origin_size]).ravel()  # x, y, size per marker
        rest = self._rest.reshape(-1, 3)
        self._at_rest = (rest, rest[:, :2], rest[:, 2])  # the noise-free field of an unloaded fingertip, shared
        self._valid = np.ones(n, bool)
        self._rng = np.random.default_rng(self.seed)
        self._noise = noise
        self._noise_scale = np.array([1.0, 1.0, 0.5]) * noise
        self._patch_key: tuple | None = ()  # the centre `_basis` was made for; () before the first
        self._errors: ErrorModel | None = None
        from drivers.sim.models.sensor_kernels import marker_field  # numba: loaded by a sensor, not by an import

        warm_up()  # the compiled wrench, field and error model loaded now, not on the first tick
        pipeline_error_model.warm_up()
        marker_field(self._rest, np.zeros((5, len(self._rest))), 0.0, 0.0, 0.0, 0.0, 0.0, np.empty((n, 3)))
        self._marker_field = marker_field  # kept: an import statement costs ~1 us a tick

    def _patch(self, centre: np.ndarray | None) -> np.ndarray:
        """(5, 3N) displacement basis of a contact centre (None: the image centre): how x, y and size of
        every marker move per unit of shear x, shear y, normal spread, torque turn and size growth (one
        matrix product a tick); kept for the last centre."""
        key = None if centre is None else (float(centre[0]), float(centre[1]))
        if key != self._patch_key:
            weight, rel = patch_weights(self.origin, self._centre if centre is None else centre, self.patch_sigma)
            basis = np.zeros((5, len(weight), 3))
            basis[0, :, 0] = basis[1, :, 1] = basis[4, :, 2] = weight
            basis[2, :, :2] = weight[:, None] * rel
            basis[3, :, 0], basis[3, :, 1] = -weight * rel[:, 1], weight * rel[:, 0]
            self._basis = basis.reshape(5, -1)
            self._patch_key = key
        return self._basis

    def state(self, contact: FingerContact, stamp: float) -> TactileState:
        """Render one `TactileState` from the loads on this fingertip."""
        exact, position, size = self._exact(contact)
        obj, slip, valid, force = contact.obj, contact.slip, self._valid, None
        if self.pipeline_errors:  # the error model also gives the wrench of the default estimator (xy_norm)
            position, size, valid, force, torque, obj, slip = self._error_model().apply(contact, exact)
        elif self._noise:
            noisy = exact + self._rng.standard_normal(exact.shape) * self._noise_scale
            position, size = noisy[:, :2], noisy[:, 2]
        markers = MarkerField(self.origin, position, self._origin_size, size, valid, self.image_size)
        if force is None or self.normal_mode != "xy_norm":
            force, torque = wrench(markers, self.finger, self.normal_mode)
        return TactileState(self.finger, stamp, markers, force, torque, obj, slip)

    def _exact(self, contact: FingerContact) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(N, 3) noise-free x, y, size of the markers and its position and size views; an unloaded
        fingertip gets the shared rest field (the same values as `_loaded`, without the product) when
        noise or the pipeline errors make new arrays of it before it is handed out."""
        if contact.normal == 0.0 and contact.torque == 0.0 and (self.pipeline_errors or self._noise):
            shear_x, shear_y = contact.shear.tolist()
            if shear_x == 0.0 and shear_y == 0.0:
                return self._at_rest
        return self._loaded(contact)

    def _loaded(self, contact: FingerContact) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The marker field of `contact`'s loads: the rest field moved by the contact centre's basis."""
        basis = self._patch(contact.centre)
        shear_x, shear_y = contact.shear.tolist()
        exact = np.empty(self._at_rest[0].shape)
        self._marker_field(self._rest, basis, self.shear_gain * shear_x, self.shear_gain * shear_y,
                           self.normal_gain * contact.normal, self.torque_gain * contact.torque,
                           self.size_gain * max(contact.normal, 0.0), exact)
        return exact, exact[:, :2], exact[:, 2]

    def _error_model(self) -> ErrorModel:
        if self._errors is None:
            markers = MarkerField(self.origin, self.origin, self._origin_size, self._origin_size, self._valid,
                                  self.image_size)
            p = self.profile
            errors = PipelineErrors(noise_px=p.noise_sigma_px, noise_persistence=p.jitter_persistence,
                                    lossy_share=p.lost_marker_share, lossy_rate=p.lost_marker_rate)
            self._errors = ErrorModel(errors, self._rng, markers, self.finger)
        return self._errors
