"""Presets load and validate; mistakes in a config file are named with a hint."""

import pytest

from perception.config import ConfigError, load_config, preset_names


def test_every_shipped_preset_loads():
    assert {"original", "thesis", "fast"} <= set(preset_names())
    for name in preset_names():
        assert load_config(name).name == name


def test_original_preset_keeps_the_2018_defaults():
    c = load_config("original")
    assert (c.threshold.mode, c.threshold.v_max, c.detector.kind, c.tracker.kind) == ("hsv", 42, "blob", "roi")
    # VSMax 1.0 and DSMaxCalib 0.5 px of OpenCV 2.4's radius-sized keypoints, as diameters.
    assert (c.tracker.search, c.tracker.max_jump, c.tracker.max_size_change, c.tracker.n_reset) == (30, 5.0, 2.0, 3)
    assert (c.calibration.max_drift, c.calibration.max_size_drift, c.calibration.min_tracked) == (0.8, 1.0, 0.0)
    assert c.tracker.lost == "origin" and c.tracker.consistency == 0
    assert not c.kalman.enabled and c.slip.method == "mog2"
    assert (c.proximity.width, c.proximity.bins, c.proximity.f_gain) == (320, (50, 10, 10), 2.5)


def test_overrides_use_dotted_or_double_underscore_keys():
    assert not load_config("fast", kalman__enabled=False).kalman.enabled
    assert load_config("fast").with_overrides({"tracker.kind": "roi"}).tracker.kind == "roi"


@pytest.mark.parametrize("text, message", [
    ("trackr: {kind: roi}\n", "did you mean 'tracker'"),
    ("tracker: {kind: nearest}\n", "not one of roi, assign, window"),
    ("kalman: {enabled: 1}\n", "expected true or false"),
    ("proximity: {bins: [50, 10]}\n", "list of 3 numbers"),
    ("threshold: {mode: adaptive, block: 20}\n", "odd number"),
    ("tracker: [1, 2]\n", "expected a mapping"),
    ("camera_fps: [\n", "malformed YAML"),
])
def test_config_file_mistakes_are_named(tmp_path, text, message):
    path = tmp_path / "mine.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=message):
        load_config(path)


def test_unknown_preset_suggests_a_name():
    with pytest.raises(ConfigError, match="did you mean 'fast'"):
        load_config("fats")


def test_config_file_mistakes_name_the_line_and_field(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text("name: mine\nkalman:\n  enabled: true\n  process_noise: abc\n")
    with pytest.raises(ConfigError) as caught:
        load_config(path)
    assert str(caught.value) == f"{path}:4: kalman.process_noise: expected a number, got 'abc'"


def test_a_file_that_is_no_config_is_refused_without_showing_its_lines(tmp_path):
    """A preset path may point anywhere (a cell file names it): its lines are not quoted back."""
    shadow = tmp_path / "shadow.yaml"
    shadow.write_text("root:$6$salt$hash:19000:0:99999:7:::\n")
    with pytest.raises(ConfigError) as caught:
        load_config(shadow)
    assert "salt" not in str(caught.value) and "no field name, not shown" in str(caught.value)
    plain = tmp_path / "plain.yaml"
    plain.write_text("just some text\n")
    with pytest.raises(ConfigError, match="a perception config is a mapping of settings, not a str"):
        load_config(plain)
