"""A FingerVision sensor profile: what one sensor does per newton, how big and how far apart its
markers are, how much they jitter at rest and how often the tracker loses them, and the camera's
rate, each number with where it came from.

One YAML file per sensor (`perception/sensor_profiles/*.yaml`; a cell file names one with
`sensor_profile:`, the default is `fingervision_default`). The simulated sensor is built from it in
both perception modes (signals and pixels), and skills read what they need of their sensor from it
(the cell's `sensor_profile`) instead of carrying a simulator's constants. A real lab writes its own
profile the same way: press known loads, measure the markers' mean motion per newton, and record the
rest jitter of a still skin.

Each entry of the file is `{value: ..., source: "..."}`; a profile without a source for a number is
refused, so a number never loses where it came from.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from fvfiles.errors import FvtreeError, did_you_mean
from fvfiles.yaml_source import Located, SourceError, load_file

PROFILE_DIR = Path(__file__).with_name("sensor_profiles")
DEFAULT_PROFILE = "fingervision_default"
# Median of a 2-D frame-to-frame step of white noise, per unit of its per-axis standard deviation:
# the step has per-axis std sigma * sqrt(2), its length is Rayleigh, whose median is sqrt(2 ln 2) its scale.
MEDIAN_STEP_PER_SIGMA = math.sqrt(2.0) * math.sqrt(2.0 * math.log(2.0))


class SensorProfileError(FvtreeError, ValueError):
    """A sensor profile file is missing, malformed or leaves a number without its source."""


@dataclass(frozen=True)
class SensorProfile:
    """One FingerVision sensor, as measured (see the default file for the sources of each value)."""

    name: str = DEFAULT_PROFILE
    normal_px_per_n: float = 0.17  # mean marker motion per N of normal load (xy_norm: the normal force reading)
    shear_px_per_n: float = 0.17  # mean marker motion per N of shear
    torque_px_per_nm: float = 1.9  # mean tangential marker motion per N m about the skin normal
    size_px_per_n: float = 0.03  # marker diameter growth per N of normal load at the contact centre
    contact_patch_px: float = 90.0  # px, width (sigma) of the region a contact moves
    marker_diameter_px: float = 10.0  # at rest
    marker_spacing_px: float = 50.0  # nearest-neighbour distance on the lattice
    marker_field_radius_px: float = 120.0  # markers lie within this distance of the image centre
    rest_jitter_px: float = 0.067  # median frame-to-frame marker step on a still skin
    jitter_persistence: float = 0.0  # lag-1 autocorrelation of the rest noise (0: independent frames)
    lost_marker_share: float = 0.105  # share of markers the tracker often loses
    lost_marker_rate: float = 0.37  # how often one of those is lost on a frame
    camera_fps: float = 30.0
    image_size: tuple[int, int] = (320, 240)
    slip_flow_gain: float = 0.65  # slip the pipeline reports per px/frame of marker motion, per unit of object area
    slip_flow_saturation: float = 1.0  # px/frame of marker motion beyond which that slip grows no more
    # The skin (drivers/sim/models/skin.py); the defaults are the default profile's skin, so a profile file
    # without them (a lab's, before `fvtree calibrate-sensor` measured its response) gets that skin.
    skin_lag_s: float = 0.033  # s, time constant of the skin's fast response to a load (0: instant)
    skin_creep_share: float = 0.05  # share of a load the skin shows only after its slow creep
    skin_creep_s: float = 3.0  # s, time constant of that creep (and of the relaxation after unloading)
    skin_hysteresis: float = 0.3  # unloading is (1 + this) times slower than loading
    sources: dict[str, str] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, float) and (not math.isfinite(value) or value < 0.0):
                raise SensorProfileError(f"{f.name} must be a finite number >= 0, got {value!r}")
        if self.skin_creep_share > 1.0:
            raise SensorProfileError(f"skin_creep_share must be in [0, 1], got {self.skin_creep_share}")
        if not 0.0 <= self.jitter_persistence < 1.0:
            raise SensorProfileError(f"jitter_persistence must be in [0, 1), got {self.jitter_persistence}")
        if self.marker_spacing_px <= self.marker_diameter_px:
            raise SensorProfileError(f"marker_spacing_px ({self.marker_spacing_px}) must exceed marker_diameter_px "
                                     f"({self.marker_diameter_px})")
        if self.normal_px_per_n <= 0.0 or self.shear_px_per_n <= 0.0 or self.camera_fps <= 0.0:
            raise SensorProfileError("normal_px_per_n, shear_px_per_n and camera_fps must be positive")

    @property
    def shear_to_normal(self) -> float:
        """How much more a newton of shear moves the markers than a newton of normal load: the weight
        a skill gives the closing-axis (normal) component to compare forces in newtons."""
        return self.shear_px_per_n / self.normal_px_per_n

    @property
    def noise_sigma_px(self) -> float:
        """Per-axis standard deviation of the marker position noise whose frame-to-frame steps have the
        profile's median `rest_jitter_px` (AR(1) noise of persistence rho: steps have variance
        2 sigma^2 (1 - rho))."""
        return self.rest_jitter_px / (MEDIAN_STEP_PER_SIGMA * math.sqrt(1.0 - self.jitter_persistence))

    def newtons(self, px: float, axis: str = "shear") -> float:
        """A marker motion in px as newtons along `axis` (shear or normal)."""
        gain = self.shear_px_per_n if axis == "shear" else self.normal_px_per_n
        return px / gain

    def as_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "sources"}


NUMBERS = tuple(f.name for f in dataclasses.fields(SensorProfile) if f.name not in ("name", "sources"))


def profile_path(name_or_path: str) -> Path:
    """A packaged profile's name (`fingervision_default`) or a path to a profile file."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.exists():
        return p
    return PROFILE_DIR / f"{name_or_path}.yaml"


def load_profile(name_or_path: str = DEFAULT_PROFILE) -> SensorProfile:
    """The sensor profile of a file (a packaged name or a path); SensorProfileError naming the file,
    line and field of what is wrong."""
    path = profile_path(name_or_path)
    if not path.exists():
        known = ", ".join(sorted(p.stem for p in PROFILE_DIR.glob("*.yaml")))
        raise SensorProfileError(f"no such sensor profile (packaged: {known})", str(path))
    try:
        data = load_file(path)
    except SourceError as exc:
        raise SensorProfileError(exc.message, str(path), exc.line, hint=exc.hint) from None
    if not isinstance(data, Located):
        raise SensorProfileError("a sensor profile is a mapping of {value, source} entries", str(path))
    values: dict[str, Any] = {"name": str(data.get("name", path.stem))}
    sources: dict[str, str] = {}
    for key in data:
        if key == "name":
            continue
        line = data.line_of(key)
        if key not in NUMBERS:
            raise SensorProfileError("unknown field", str(path), line, key, did_you_mean(key, NUMBERS))
        entry = data[key]
        if not isinstance(entry, dict) or set(entry) != {"value", "source"} or not str(entry["source"]).strip():
            raise SensorProfileError("must be {value: ..., source: \"where the number comes from\"}", str(path),
                                     line, key)
        value = entry["value"]
        if key == "image_size":
            if not (isinstance(value, list) and len(value) == 2 and all(isinstance(v, int) for v in value)):
                raise SensorProfileError(f"must be [width, height] in px, got {value!r}", str(path), line, key)
            value = (value[0], value[1])
        elif isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SensorProfileError(f"must be a number, got {value!r}", str(path), line, key)
        else:
            value = float(value)
        values[key] = value
        sources[key] = str(entry["source"])
    try:
        return SensorProfile(**values, sources=sources)
    except SensorProfileError as exc:
        raise SensorProfileError(exc.message, str(path)) from None


def save_profile(profile: SensorProfile, path: str | Path) -> Path:
    """Write `profile` in the packaged profiles' format (every number as {value, source}); a number
    without a source is refused, as `load_profile` would refuse it."""
    doc: dict[str, Any] = {"name": profile.name}
    for key, value in profile.as_dict().items():
        if key == "name":
            continue
        source = profile.sources.get(key, "").strip()
        if not source:
            raise SensorProfileError("a number without its source cannot be written", str(path), field=key)
        doc[key] = {"value": list(value) if key == "image_size" else value, "source": source}
    path = Path(path)
    path.write_text(yaml.safe_dump(doc, sort_keys=False, width=110, allow_unicode=True))
    return path


_cache: dict[str, SensorProfile] = {}


def default_profile() -> SensorProfile:
    """The shipped default profile (read once)."""
    if DEFAULT_PROFILE not in _cache:
        _cache[DEFAULT_PROFILE] = load_profile(DEFAULT_PROFILE)
    return _cache[DEFAULT_PROFILE]
