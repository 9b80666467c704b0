"""Pixel mode's appearance (`drivers/sim/models/appearance.py`): the default look renders the frames it
always did, each variation changes the image the way it says, looks are drawn per seed within their
ranges, cell files set them with located errors, and the pipeline warns when the object colour model
takes part of the empty view for the object (the paper's lighting and object-colour failure)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from assembly.bench.appearance import measure
from drivers.cell_builders import load_cell
from drivers.cell_file import CellFileError
from drivers.sim.models.appearance import DEFAULT_LOOK, LOOK_RANGES, Look, draw_look, look_from
from drivers.sim.models.fingervision_model import SensorModel
from drivers.sim.models.synthetic_camera import Appearance, SyntheticFingerVision
from perception.state import ObjectInfo

ORIGIN = SensorModel("left").origin
CLEAN = Appearance(noise=0.0)
OBJECT = ObjectInfo(True, 0.3, np.zeros(2), 0.0)


def camera(look: Look = DEFAULT_LOOK, seed: int = 3) -> SyntheticFingerVision:
    return SyntheticFingerVision(ORIGIN, seed=seed, clutter=look.background_clutter,
                                 background_tint=look.background_tint, object_bgr=look.object_bgr)


def lit(look: Look) -> Appearance:
    return Appearance(noise=0.0, gain=look.brightness, gradient=look.gradient, glare=look.glare, cast=look.colour_cast)


def test_the_default_look_renders_the_frames_the_camera_always_drew():
    plain = SyntheticFingerVision(ORIGIN, seed=3).render(obj=OBJECT)
    looked = camera().render(obj=OBJECT, appearance=Appearance(cast=(1.0, 1.0, 1.0)))
    np.testing.assert_array_equal(plain.image, looked.image)


def test_each_variation_changes_the_image_as_it_says():
    base = camera().render(obj=OBJECT, appearance=CLEAN)
    window = base.truth.object_mask  # the object's pixels
    inside = ~window & (np.hypot(*(np.mgrid[0:240, 0:320][::-1] - np.array([160, 120])[:, None, None])) < 100)
    dim = camera().render(obj=OBJECT, appearance=lit(Look(brightness=0.6))).image.astype(float)
    assert dim[inside].mean() / base.image[inside].mean() == pytest.approx(0.6, rel=0.03)
    warm = camera().render(obj=OBJECT, appearance=lit(Look(colour_cast=(0.8, 1.0, 1.2)))).image.astype(float)
    ratio = warm[inside].mean(axis=0) / base.image[inside].mean(axis=0)
    assert ratio[0] == pytest.approx(0.8, rel=0.03) and ratio[2] > 1.1  # red saturates in places
    ramp = camera().render(appearance=lit(Look(gradient=0.6))).image.astype(float)
    flat = camera().render(appearance=CLEAN).image.astype(float)
    assert ramp[:, 200:260].mean() / flat[:, 200:260].mean() > ramp[:, 60:120].mean() / flat[:, 60:120].mean() + 0.2
    tinted = camera(Look(background_tint=(0.5, 0.5, 0.5))).render(obj=OBJECT, appearance=CLEAN)
    assert tinted.image[inside].mean() < 0.7 * base.image[inside].mean()
    core = cv2.erode(window.view(np.uint8), np.ones((5, 5), np.uint8)) > 0  # clear of the soft edge
    np.testing.assert_array_equal(tinted.image[core], base.image[core])  # the object is not behind the skin
    blue = camera(Look(object_bgr=(235.0, 120.0, 40.0))).render(obj=OBJECT, appearance=CLEAN)
    assert blue.image[window].mean(axis=0)[0] > 150 > base.image[window].mean(axis=0)[0]
    glared = camera().render(appearance=lit(Look(glare=0.1)))
    assert (glared.image >= 250).all(axis=2).mean() > 0.02 and not glared.truth.visible.all()


def test_looks_are_drawn_per_seed_within_their_ranges():
    looks = [look_from("random", seed) for seed in range(20)]
    assert looks[3] == look_from("random", 3) and len(set(looks)) == 20
    for look in looks:
        for name in ("brightness", "gradient", "glare", "background_clutter"):
            low, high = LOOK_RANGES[name]
            assert low <= getattr(look, name) <= high
        assert all(LOOK_RANGES["colour_cast"][0] <= c <= LOOK_RANGES["colour_cast"][1] for c in look.colour_cast)
    assert draw_look(np.random.default_rng(1)) == draw_look(np.random.default_rng(1))
    assert look_from(None, 5) == DEFAULT_LOOK


def test_a_cell_file_sets_the_look_and_a_bad_field_says_where(tmp_path):
    cell_file = tmp_path / "cell.yaml"
    cell_file.write_text("kind: sim\npixel_workers: false\nsensor:\n  appearance: {brightness: 0.7, colour_cast: [1.1, 1.0, 0.9]}\n")
    cell = load_cell(str(cell_file), 30.0, scene="press", perception="pixels")
    try:
        cell.clock.advance()
        assert all(state.healthy for state in cell.sense().values())
    finally:
        cell.close()
    for text, message in [("{brightnes: 0.7}", "did you mean"), ("{brightness: -1}", "brightness must be > 0"),
                          ("{colour_cast: [1, 2]}", "three numbers"), ("sunny", "or 'random'")]:
        cell_file.write_text(f"kind: sim\nsensor:\n  appearance: {text}\n")
        with pytest.raises(CellFileError, match=message) as info:
            load_cell(str(cell_file), 30.0, scene="press")  # checked in signals mode too
        assert "sensor.appearance" in str(info.value.field) and Path(str(info.value.path)).name == "cell.yaml"


def test_the_pipeline_warns_when_the_object_colour_matches_the_empty_view():
    """A grey object on a grey-green bench: the colour model marked on the object also covers the
    empty view, so the object's area is garbage (1.8x the drawn one); every state says so. The default
    orange object is seen at its usual share (the proximity mask's 0.67) without a warning."""
    default, grey = measure(DEFAULT_LOOK), measure(Look(object_bgr=(128.0, 128.0, 128.0)))
    assert default["object warned"] == 0.0 and default["area seen / drawn"] == pytest.approx(0.67, abs=0.05)
    assert default["object seen in an empty view"] == 0.0
    assert grey["object seen in an empty view"] == 1.0 and grey["area seen / drawn"] > 1.5
    assert grey["object warned"] == 1.0 and grey["healthy"] == 1.0  # the markers are fine; the object is not
    assert grey["warned match"] == pytest.approx(grey["empty view's object area"], abs=0.01)
