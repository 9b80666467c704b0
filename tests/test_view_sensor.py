"""`fvtree sensor` (assembly/observe/sensor_view.py) on the real FingerVision clip: it calibrates,
saves a marker map that loads back, and records image, markers, health and wrench per frame."""

from __future__ import annotations

from pathlib import Path

import pytest

from assembly.cli import main
from assembly.observe.readback import read_recording
from fvfiles.errors import FvtreeError
from perception.calibration import MarkerMap

ROOT = Path(__file__).resolve().parents[1]
CLIP = ROOT.parent / "shared" / "data" / "fv_demo" / "cam1_0002.m4v"


@pytest.mark.skipif(not CLIP.is_file(), reason=f"the real FingerVision clip is not at {CLIP}")
def test_sensor_view_calibrates_saves_the_map_and_records_each_frame(tmp_path, capsys):
    marker_map, recording = tmp_path / "map.yaml", tmp_path / "sensor.rrd"
    assert main(["sensor", str(CLIP), "--frames", "40", "--no-view", "--save", str(recording),
                 "--map", str(marker_map), "--image-every", "2"]) == 0
    out = capsys.readouterr().out
    loaded = MarkerMap.load(marker_map)
    assert len(loaded) >= 20 and loaded.image_size == (320, 240)
    assert f"calibrated {len(loaded)} markers" in out and "40 frames" in out
    rec = read_recording(recording)
    assert [r["frame"] for r in rec["sensor/image/markers"]] == list(range(40))
    assert len(rec["sensor/image"]) == 20  # every second image
    assert len(rec["sensor/force"]) == 41  # 40 frames and the series names
    markers = rec["sensor/image/markers"][0]["Points2D:positions"]
    assert len(markers) == len(loaded)
    assert rec["sensor/health"][0]["TextLog:text"][0].startswith(("healthy", "unhealthy: "))
    assert rec["sensor/calibration"][0]["TextDocument:text"][0].startswith(f"{len(loaded)} markers, image 320x240 px")


def test_sensor_view_names_a_missing_file(tmp_path):
    from assembly.observe.sensor_view import parse_source

    with pytest.raises(FvtreeError, match="no such video file"):
        parse_source(str(tmp_path / "nope.mp4"))
    assert parse_source("0") == 0 and parse_source("http://127.0.0.1:8080/stream.mjpg").startswith("http")
