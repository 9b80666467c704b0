"""What a pixel-mode fingertip camera looks at besides the markers: the lighting, what lies behind the
skin, and the object's colour (`Look`), with the ranges a real cell spans (`LOOK_RANGES`).

The FingerVision paper's main practical failure is "the high sensitivity of the vision-based blob
detection to lighting conditions and object color" (the thesis painted its test objects bright orange
because background items of similar colour were taken for the object). The synthetic camera draws one
default look; a cell file varies it with `sensor: {appearance: {...}}` (fields of `Look`), or draws it
per seed with `sensor: {appearance: random}` (`draw_look`). The defaults are the synthetic camera's own
look, so default runs render the same frames as before. Signals mode ignores the look: its error model
was measured on the default one.

Ranges (what `draw_look` draws from, uniform unless said):
- brightness 0.6-1.4: a lamp moved, exposure set for another light (1 = the default look);
- gradient 0-0.6: light falling from one side across the window (share of the gain, left to right);
- glare 0-0.1: share of the window washed out by a specular highlight (a shiny object, a lamp's
  reflection in the acrylic);
- colour_cast 0.8-1.2 per B, G, R channel: warm or cold light, white balance off;
- background_clutter 0-40 shapes, background_tint 0.5-1.5 per channel: what lies behind the skin
  (a bare table, a cluttered bench, a coloured wall);
- object_bgr: any hue, saturation 0.25-1, value 0.35-1 (HSV, as OpenCV counts: hue 0-180).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from drivers.sim.models.object_layer import OBJECT_BGR

Triple = tuple[float, float, float]

LOOK_RANGES: dict[str, tuple[float, float]] = {
    "brightness": (0.6, 1.4),
    "gradient": (0.0, 0.6),
    "glare": (0.0, 0.1),
    "colour_cast": (0.8, 1.2),  # per channel
    "background_clutter": (0.0, 40.0),
    "background_tint": (0.5, 1.5),  # per channel
    "object_saturation": (0.25, 1.0),  # HSV share of the object colour
    "object_value": (0.35, 1.0),
}


@dataclass(frozen=True)
class Look:
    """The lighting, background and object colour of one cell's fingertip cameras (defaults: the
    synthetic camera's own look; see the module docstring for the ranges)."""

    brightness: float = 1.0  # lighting gain on the whole image
    gradient: float = 0.0  # lighting change across the image, share of the gain (left to right)
    glare: float = 0.0  # share of the window washed out by a specular highlight
    colour_cast: Triple = (1.0, 1.0, 1.0)  # B, G, R gains of the light
    background_clutter: int = 14  # shapes behind the skin
    background_tint: Triple = (1.0, 1.0, 1.0)  # B, G, R gains of what lies behind the skin
    object_bgr: Triple = OBJECT_BGR  # the object's colour, 0-255 per channel

    def __post_init__(self) -> None:
        for name in ("brightness", "gradient", "glare"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"{name} must be a number, got {value!r}")
        if self.brightness <= 0.0 or not 0.0 <= self.gradient < 2.0 or not 0.0 <= self.glare <= 0.5:
            raise ValueError(f"brightness must be > 0, gradient in [0, 2), glare in [0, 0.5]; got "
                             f"{self.brightness}, {self.gradient}, {self.glare}")
        if isinstance(self.background_clutter, bool) or not isinstance(self.background_clutter, int) \
                or not 0 <= self.background_clutter <= 200:
            raise ValueError(f"background_clutter must be a whole number of shapes 0-200, got {self.background_clutter!r}")
        for name, top in (("colour_cast", 4.0), ("background_tint", 4.0), ("object_bgr", 255.0)):
            value = getattr(self, name)
            if not (isinstance(value, tuple) and len(value) == 3
                    and all(isinstance(v, (int, float)) and not isinstance(v, bool) and 0.0 <= v <= top
                            for v in value)):
                raise ValueError(f"{name} must be three numbers (B, G, R) in [0, {top:g}], got {value!r}")


DEFAULT_LOOK = Look()


def draw_look(rng: np.random.Generator) -> Look:
    """A look drawn from `LOOK_RANGES` (the randomised cell's, one per seed)."""
    def uniform(name: str, n: int | None = None):
        low, high = LOOK_RANGES[name]
        return rng.uniform(low, high) if n is None else rng.uniform(low, high, n)

    brightness, gradient, glare = uniform("brightness"), uniform("gradient"), uniform("glare")
    cast, tint = uniform("colour_cast", 3), uniform("background_tint", 3)
    clutter = round(float(uniform("background_clutter")))
    hsv = np.array([[[rng.uniform(0.0, 180.0), 255.0 * uniform("object_saturation"),
                      255.0 * uniform("object_value")]]], np.float32)
    colour = cv2.cvtColor(hsv.astype(np.uint8), cv2.COLOR_HSV2BGR)[0, 0]
    return Look(float(brightness), float(gradient), float(glare), _triple(cast), clutter, _triple(tint),
                _triple(colour))


def look_from(value: object, seed: int) -> Look:
    """The look of a cell file's `sensor.appearance` when it is not a mapping of `Look` fields: absent
    (the default look) or `random` (drawn for `seed`); ValueError otherwise (the caller names the file
    and field)."""
    if value is None:
        return Look()
    if value == "random":
        return draw_look(np.random.default_rng([seed, 0xA99E]))
    raise ValueError(f"must be a mapping of appearance fields or 'random', got {value!r}")


def _triple(values) -> Triple:
    a, b, c = (float(v) for v in values)
    return (a, b, c)
