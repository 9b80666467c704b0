"""The FingerVision pipeline under each lighting, background and object-colour variation of pixel mode
(`drivers/sim/models/appearance.py`): `python -m assembly.bench.appearance [OUT]` renders one fingertip
with each variation at the end of its range (one at a time, the rest the default look) and with looks
drawn at random, runs the real pipeline on it as pixel mode does (calibrated on the look's own frames,
the object's colour marked on three of its frames) and writes appearance.md (or prints it): per
variation, the markers calibrated and tracked, whether the states say healthy, the object seen with
nothing in view, and the object's area and centroid as seen against the drawn truth while a 10 N
contact presses it. What breaks the pipeline is a row whose markers or object go wrong; whether its
states say so is in the `healthy` and `object warned` columns (the share of the empty view the
object colour model matches, as the warning gives it: `warned match`).
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

from drivers.sim.models.appearance import DEFAULT_LOOK, Look, draw_look
from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.models.synthetic_camera import FingerRig, PixelFinger, drawn_jitter
from perception.fingervision import background_match_of
from perception.state import ObjectInfo

OBJECT = ObjectInfo(True, 0.3, np.array([0.05, -0.03]), 0.2)  # the held object as the scenes show it
EMPTY_FRAMES, HELD_FRAMES = 30, 60  # frames with nothing in view, then with the object pressed

VARIATIONS: dict[str, Look] = {
    "default": DEFAULT_LOOK,
    "dim (brightness 0.6)": Look(brightness=0.6),
    "bright (brightness 1.4)": Look(brightness=1.4),
    "gradient 0.6": Look(gradient=0.6),
    "glare 0.1": Look(glare=0.1),
    "warm cast (B 0.8, R 1.2)": Look(colour_cast=(0.8, 1.0, 1.2)),
    "cold cast (B 1.2, R 0.8)": Look(colour_cast=(1.2, 1.0, 0.8)),
    "bare background (0 shapes)": Look(background_clutter=0),
    "busy background (40 shapes)": Look(background_clutter=40),
    "dark background (tint 0.5)": Look(background_tint=(0.5, 0.5, 0.5)),
    "bright background (tint 1.5)": Look(background_tint=(1.5, 1.5, 1.5)),
    "orange background (tint B 0.5, R 1.5)": Look(background_tint=(0.5, 0.9, 1.5)),
    "blue object": Look(object_bgr=(235.0, 120.0, 40.0)),
    "green object": Look(object_bgr=(60.0, 200.0, 60.0)),
    "grey object": Look(object_bgr=(128.0, 128.0, 128.0)),
    "dark object": Look(object_bgr=(30.0, 45.0, 70.0)),
    "white object": Look(object_bgr=(235.0, 235.0, 235.0)),
}


def measure(look: Look, seed: int = 0) -> dict:
    """One fingertip through the pipeline with `look`: marker and object figures (see the module doc)."""
    model = SensorModel("left", noise_px=0.0)
    profile = model.profile
    rig = FingerRig("left", model.origin, model.marker_size, profile.image_size, seed, "fast", profile.camera_fps,
                    drawn_jitter(profile), profile.jitter_persistence, look)
    finger = PixelFinger(rig)
    calibrated = len(finger.pipeline.marker_map or ())  # calibrated by PixelFinger
    rest = model.state(FingerContact(), 0.0).markers
    held = model.state(FingerContact(10.0, obj=OBJECT), 0.0).markers
    states, truths = [], []
    for i in range(EMPTY_FRAMES + HELD_FRAMES):
        markers, obj = (rest, None) if i < EMPTY_FRAMES else (held, OBJECT)
        frame = finger.camera.render(markers.position, markers.size, obj, 0.0, finger.appearance)  # as process()
        states.append(finger.pipeline.process(frame.image, i / profile.camera_fps))
        truths.append(frame.truth.obj)
    empty = states[EMPTY_FRAMES // 2:EMPTY_FRAMES]
    pressed = states[-HELD_FRAMES // 2:]
    truth = truths[-1]
    seen = [s.obj for s in pressed if s.obj.present]
    area = float(np.median([o.area for o in seen])) / truth.area if seen else 0.0
    centroid = float(np.median([np.linalg.norm(o.centroid - truth.centroid) for o in seen])) if seen else float("nan")
    tracked = float(np.mean([s.markers.valid[:calibrated].mean() for s in states]))
    return {"markers calibrated": calibrated, "markers tracked": round(tracked, 3),
            "healthy": round(float(np.mean([s.healthy for s in states])), 3),
            "object seen in an empty view": round(float(np.mean([s.obj.present for s in empty])), 3),
            "empty view's object area": round(float(np.median([s.obj.area for s in empty])), 4),
            "object seen": round(len(seen) / len(pressed), 3), "area seen / drawn": round(area, 3),
            "centroid error": round(centroid, 4),
            "object warned": round(float(np.mean([background_match_of(s.health_reason) > 0.0 for s in pressed])), 3),
            "warned match": round(max(background_match_of(s.health_reason) for s in pressed), 4)}


def table(rows: dict[str, dict]) -> str:
    """The markdown table of `rows` (variation -> measure's figures)."""
    columns = list(next(iter(rows.values())))
    lines = ["| variation | " + " | ".join(columns) + " |", "|---" * (len(columns) + 1) + "|"]
    lines += [f"| {name} | " + " | ".join(str(row[c]) for c in columns) + " |" for name, row in rows.items()]
    return "\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    rows = {name: measure(look) for name, look in VARIATIONS.items()}
    for seed in range(int(argv[1]) if len(argv) > 1 else 5):
        look = draw_look(np.random.default_rng([seed, 0xA99E]))
        rows[f"random look, seed {seed}"] = measure(look, seed)
        rows[f"random look, seed {seed}"]["look"] = {k: (np.round(v, 2).tolist() if isinstance(v, tuple) else round(v, 2))
                                                    for k, v in dataclasses.asdict(look).items()}
    for row in rows.values():
        row.setdefault("look", "")
    text = "# Pixel mode's pipeline under appearance variations\n\n" + table(rows)
    if argv:
        Path(argv[0]).mkdir(parents=True, exist_ok=True)
        (Path(argv[0]) / "appearance.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
