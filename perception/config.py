"""Pipeline configuration: typed, validated settings and named YAML presets.

A preset is a YAML file in `perception/presets/` (`original`: the 2018-era FingerVision defaults;
`thesis`: `original` plus the thesis Kalman filter; `fast`: the quickest setting that keeps the
accuracy targets). Any key left out of a YAML file keeps the dataclass default below.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from fvfiles.errors import FvtreeError, did_you_mean, did_you_mean_field, field_name
from fvfiles.yaml_source import Located, SourceError, load_file

PRESET_DIR = Path(__file__).with_name("presets")


class ConfigError(FvtreeError, ValueError):
    """A perception config file or override is malformed; the message names the key."""


@dataclass(frozen=True)
class ThresholdConfig:
    """Marker mask: `hsv` is the original fixed V threshold, `adaptive` compares with the local mean."""

    mode: Literal["hsv", "adaptive"] = "hsv"
    v_max: int = 42  # hsv: pixels with V <= v_max are marker pixels (ThreshV)
    block: int = 21  # adaptive: odd neighbourhood size in px
    offset: float = 25.0  # adaptive: grey levels darker than the local mean
    n_dilate: int = 0  # NDilate1
    n_erode: int = 0  # NErode1


@dataclass(frozen=True)
class DetectorConfig:
    """Full-frame blob detector: `blob` (SimpleBlobDetector, original) or `cc` (connected components)."""

    kind: Literal["blob", "cc"] = "cc"
    min_area: float = 10.0  # px^2
    max_area: float = 150.0
    min_circularity: float = 0.10
    min_convexity: float = 0.87
    min_inertia_ratio: float = 0.01
    min_dist_between: float = 10.0
    min_repeatability: int = 2
    blob_thresholds: tuple[float, float, float] = (5.0, 200.0, 10.0)  # min, max, step
    split: bool = False  # cc: open rejected components with a marker-sized disc to free merged markers


@dataclass(frozen=True)
class TrackerConfig:
    """Frame-to-frame marker tracking and its gates (names of the original in comments)."""

    kind: Literal["roi", "assign", "window"] = "window"
    search: int = 30  # SWidth: ROI side in px (roi tracker)
    max_jump: float = 5.0  # VPMax: px from the predicted position
    max_size_change: float = 1.0  # VSMax: px of diameter from the predicted size
    n_reset: int = 3  # NReset: reset a marker to its origin after more failures than this
    nonzero_range: tuple[float, float] = (0.3, 3.0)  # NonZeroMin/Max of the ROI mask fill
    window: float = 0.0  # window tracker: half side in px; 0 = marker radius + 3
    min_contrast: float = 20.0  # window tracker: grey levels between background and marker core
    area_range: tuple[float, float] = (0.5, 1.6)  # window tracker: dark area over the last tracked size's
    max_ring_dark: float = 1.0  # window tracker: largest dark share of the ring around a marker (1 = off)
    consistency: float = 0.0  # px; flag markers off their neighbours' local deformation (0 = off)
    neighbours: int = 6  # neighbours used by the consistency check and to re-find lost markers
    lost: Literal["origin", "neighbours"] = "neighbours"  # where a lost marker is searched (original: origin)
    # window tracker: markers still lost after the neighbours' look are searched for the nearest marker-like
    # blob within this share of the calibrated marker spacing (a jump of several px in one frame); 0 = off
    reacquire: float = 0.0


@dataclass(frozen=True)
class CalibrationConfig:
    """No-contact calibration of the marker map (`Calibrate` of the original)."""

    n_frames: int = 10  # NCalibPoints
    max_drift: float = 0.8  # DistMaxCalib, px
    max_size_drift: float = 1.0  # DSMaxCalib, px of diameter (0.5 of OpenCV 2.4's radius-sized keypoints)
    origin: Literal["first", "mean"] = "mean"  # original: the first frame's detection
    min_tracked: float = 0.5  # share of frames a marker must be tracked in (original: 0, drift only)
    max_ring: float = 1.0  # largest dark share of the ring around a kept marker (window tracker; 1 = any)
    lattice_ring: float = 0.0  # up to this ring share, a marker on the lattice of the others is kept too


@dataclass(frozen=True)
class LateMarkerConfig:
    """Markers missed at calibration (covered, or merged with a dark edge) and added once they are
    plainly visible at one place on the skin (`perception.late_markers`; with the window tracker only,
    the others keep their calibrated map as the original)."""

    enabled: bool = False
    every: int = 15  # frames between two searches of the lattice holes
    confirm: int = 4  # consecutive searches a candidate must pass at one place on the skin
    max_drift: float = 0.8  # px its rest position may move over those searches


@dataclass(frozen=True)
class KalmanConfig:
    """Per-marker Kalman filter of the thesis, state [x0, xt, y0, yt, s], vectorised."""

    enabled: bool = True
    process_noise: float = 0.01
    measurement_noise: float = 0.1
    initial_cov: float = 0.1
    reinit_gate: float = 0.0  # chi-square (2 dof) of the innovation that restarts a marker; 0 = off
    motion_gate: float = 0.0  # chi-square (2 dof) of a neighbourhood's mean innovation that restarts it; 0 = off


@dataclass(frozen=True)
class WrenchConfig:
    """Force/torque estimation from the marker field (see `perception.wrench`)."""

    normal_mode: Literal["xy_norm", "marker_size"] = "xy_norm"
    averaging: Literal["mean", "median", "robust"] = "mean"
    force_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)  # px -> calibrated unit
    torque_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class ProximityConfig:
    """Proximity vision (`TObjDetTrackBSP` of the original) on a resized frame."""

    enabled: bool = True
    width: int = 160
    height: int = 120
    thresh_blk_v: int = 1  # ThreshBlkV
    bins: tuple[int, int, int] = (50, 10, 10)  # H, S, V
    f_gain: float = 2.5
    f_bg: float = 1.0
    n_models: int = 5
    frames_in_hist: int = 200
    backproj_scale: float = 5.0
    mask_threshold: int = 150
    n_erode: int = 2
    n_dilate: int = 7
    n_bg_frames: int = 3
    min_area: float = 0.005  # object present when its mask covers this share of the image


@dataclass(frozen=True)
class SlipConfig:
    """Slip: moving object pixels by `mog2` (original) or `flow` (DIS optical flow), or `off`."""

    method: Literal["mog2", "flow", "off"] = "mog2"
    step: int = 1  # mog2: model every step-th pixel of each axis, each result spread over its step x step block
    history: int = 30
    var_threshold: float = 10.0
    shadows: bool = True
    learning_rate: float = 1.0 / 30.0
    flow_preset: Literal["ultrafast", "fast", "medium"] = "ultrafast"
    min_speed: float = 1.0  # flow: px per frame at 320x240 counted as motion


@dataclass(frozen=True)
class HealthConfig:
    """When a state is flagged unhealthy."""

    min_tracked: float = 0.5  # share of calibrated markers in view (`fingervision.in_view`) tracked this frame
    dark_level: float = 15.0  # mean grey level below which the image is too dark
    saturated_share: float = 0.5  # share of pixels at >= 250 above which it is washed out
    frozen_frames: int = 5  # identical consecutive frames before the camera counts as frozen
    # A part of the image frozen while the rest lives (a decoder concealing truncated JPEGs with
    # the last good pixels): one of 4 x 4 regions with at least `frozen_region_share` of its
    # pixels identical to the last frame for `frozen_region_frames` frames in a row, while another
    # region changes in most of its pixels. The real clip's longest such run is 2 frames (H.264
    # copies still blocks exactly); 0 turns the check off.
    frozen_region_frames: int = 10
    frozen_region_share: float = 0.98


@dataclass(frozen=True)
class FingerVisionConfig:
    """Everything `FingerVision` needs, one section per stage."""

    name: str = "custom"
    camera_fps: float = 30.0  # the Kalman filter's dt = 1 / camera_fps
    threshold: ThresholdConfig = field(default_factory=ThresholdConfig)
    detector: DetectorConfig = field(default_factory=DetectorConfig)
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    calibration: CalibrationConfig = field(default_factory=CalibrationConfig)
    late: LateMarkerConfig = field(default_factory=LateMarkerConfig)
    kalman: KalmanConfig = field(default_factory=KalmanConfig)
    wrench: WrenchConfig = field(default_factory=WrenchConfig)
    proximity: ProximityConfig = field(default_factory=ProximityConfig)
    slip: SlipConfig = field(default_factory=SlipConfig)
    health: HealthConfig = field(default_factory=HealthConfig)

    def with_overrides(self, overrides: Mapping[str, Any]) -> FingerVisionConfig:
        """A copy with dotted keys replaced, e.g. {"kalman.enabled": False}."""
        data = dataclasses.asdict(self)
        for key, value in overrides.items():
            node = data
            parts = key.split(".")
            for part in parts[:-1]:
                if not isinstance(node.get(part), dict):
                    raise ConfigError(f"override {key!r}: {part!r} is not a config section")
                node = node[part]
            if parts[-1] not in node:
                raise ConfigError(f"override {key!r}: unknown key{_hint(parts[-1], node)}")
            node[parts[-1]] = value
        return from_dict(data, source="overrides")


def _hint(key: str, known) -> str:
    return f"; {did_you_mean(key, known) or 'known: ' + ', '.join(sorted(known))}"


def _coerce(value: Any, kind: Any, where: str) -> Any:
    """Check one YAML value against its annotated type and convert lists to tuples."""
    text = str(kind)
    if text.startswith("tuple"):
        n = text.count(",") + 1
        if not isinstance(value, (list, tuple)) or len(value) != n:
            raise ConfigError(f"expected a list of {n} numbers, got {value!r}", field=where)
        return tuple(_coerce(v, text[6:-1].split(",")[0].strip(), where) for v in value)
    if text.startswith("Literal"):
        allowed = [a.strip().strip("'\"") for a in text[8:-1].split(",")]
        if value not in allowed:
            raise ConfigError(f"{value!r} is not one of {', '.join(allowed)}", field=where)
        return value
    if text == "bool":
        if not isinstance(value, bool):
            raise ConfigError(f"expected true or false, got {value!r}", field=where)
        return value
    if text in ("int", "float"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"expected a number, got {value!r}", field=where)
        if text == "int" and float(value) != int(value):
            raise ConfigError(f"expected an integer, got {value!r}", field=where)
        return int(value) if text == "int" else float(value)
    if text == "str":
        return str(value)
    raise ConfigError(f"unsupported type {text}", field=where)  # a programming error in this module


def _build(cls, data: Any, where: str):
    """`cls` from mapping `data` at dotted `where`; a problem raises a ConfigError naming the field
    and, for a mapping read from a file, the line of its key."""
    if not isinstance(data, Mapping):
        raise ConfigError(f"expected a mapping, got {type(data).__name__}", field=where or None)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    lines = data.line_of if isinstance(data, Located) else lambda _key: None
    kwargs = {}
    for key, value in data.items():
        if key not in fields:  # quoted only when it looks like a field name: a file that is no config stays unread
            raise ConfigError(f"unknown key {field_name(key)}", line=lines(key), field=where or None,
                              hint=did_you_mean_field(key, fields) or "known: " + ", ".join(sorted(fields)))
        sub = f"{where}.{key}" if where else key
        default = fields[key].default_factory
        try:
            if default is not dataclasses.MISSING and dataclasses.is_dataclass(default):
                kwargs[key] = _build(default, value, sub)
            else:
                kwargs[key] = _coerce(value, fields[key].type, sub)
        except ConfigError as exc:
            if exc.line is None:
                exc.line = lines(key)
            raise
    return cls(**kwargs)


def from_dict(data: Mapping[str, Any], source: str = "config") -> FingerVisionConfig:
    """Validate a nested mapping into a config; unknown keys and bad values raise `ConfigError`."""
    try:
        config = _build(FingerVisionConfig, data, "")
    except ConfigError as exc:
        raise ConfigError(exc.message, source, exc.line, exc.field, exc.hint) from None
    _check(config, source)
    return config


def _check(c: FingerVisionConfig, source: str) -> None:
    """Cross-field checks that types alone cannot express."""
    problems = []
    if c.camera_fps <= 0:
        problems.append("camera_fps must be positive")
    if c.threshold.mode == "adaptive" and (c.threshold.block < 3 or c.threshold.block % 2 == 0):
        problems.append("threshold.block must be an odd number >= 3")
    if c.calibration.n_frames < 2:
        problems.append("calibration.n_frames must be at least 2 (one to detect, one to check)")
    if c.kalman.enabled and min(c.kalman.process_noise, c.kalman.measurement_noise,
                                c.kalman.initial_cov) <= 0:
        problems.append("kalman noise and covariance values must be positive")
    if c.proximity.width < 24 or c.proximity.height < 24:
        problems.append("proximity.width and height must be at least 24 px")
    if c.slip.step < 1:
        problems.append("slip.step must be at least 1 (1: every pixel)")
    if c.late.every < 1 or c.late.confirm < 2:
        problems.append("late.every must be at least 1 and late.confirm at least 2")
    if c.health.frozen_region_frames < 0 or not 0.5 < c.health.frozen_region_share <= 1.0:
        problems.append("health.frozen_region_frames must be >= 0 (0: off) and health.frozen_region_share "
                        "in (0.5, 1]")
    if c.tracker.area_range[0] >= c.tracker.area_range[1]:
        problems.append("tracker.area_range must be [low, high] with low < high")
    if problems:
        raise ConfigError(f"{source}: " + "; ".join(problems))


def preset_names() -> list[str]:
    """Names of the shipped presets."""
    return sorted(p.stem for p in PRESET_DIR.glob("*.yaml"))


def load_config(preset: str | Path = "fast", **overrides: Any) -> FingerVisionConfig:
    """Load a named preset or a YAML file, then apply dotted overrides (`kalman__enabled=False`)."""
    path = Path(preset)
    if path.suffix not in (".yaml", ".yml"):
        path = PRESET_DIR / f"{preset}.yaml"
        if not path.is_file():
            raise ConfigError(f"no perception preset {str(preset)!r}{_hint(str(preset), preset_names())}")
    try:
        data = load_file(path) or {}  # read with limits: size, aliases, depth, UTF-8, no NaN
    except SourceError as exc:
        raise ConfigError(f"perception config: {exc}") from None
    if not isinstance(data, Mapping):  # what it holds is not shown: the file may be no config at all
        raise ConfigError(f"a perception config is a mapping of settings, not a {type(data).__name__}", str(path))
    data.setdefault("name", path.stem)
    config = from_dict(data, source=str(path))
    if overrides:
        config = config.with_overrides({k.replace("__", "."): v for k, v in overrides.items()})
    return config
