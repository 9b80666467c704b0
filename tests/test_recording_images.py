"""Camera frames in a run's recording (`fvtree run --record-images HZ`): a pixel-mode run records
each finger's rendered frame as a JPEG at the chosen rate of cell time, in the marker arrows' pixel
axes; a signals-mode run has no images, and 0 turns them off."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from assembly.observe.readback import read_recording
from assembly.run.options import RunOptions
from assembly.run.perception_stage import clear_blackboard
from assembly.run.session import run_tree

HOLD = Path(__file__).resolve().parents[1] / "trees" / "hold.yaml"
SECONDS = 3.0  # of cell time: 90 ticks at 30 Hz


def _recorded(tmp_path: Path, perception: str, hz: float) -> dict:
    clear_blackboard()
    summary = run_tree(str(HOLD), RunOptions(perception=perception, runs_dir=tmp_path, max_time=SECONDS, plots=False, quiet=True, record_images=hz))
    return read_recording(Path(summary.run_dir) / "recording.rrd")


def _decoded(row: dict) -> np.ndarray:
    assert row["EncodedImage:media_type"] == ["image/jpeg"]
    return cv2.imdecode(np.frombuffer(bytes(row["EncodedImage:blob"][0]), np.uint8), cv2.IMREAD_COLOR)


@pytest.fixture(scope="module")
def pixel_recording(tmp_path_factory) -> dict:
    return _recorded(tmp_path_factory.mktemp("runs"), "pixels", 5.0)


def test_pixel_mode_records_each_finger_frame_at_the_chosen_rate(pixel_recording):
    last = max(r["tick"] for r in pixel_recording["robot/pose"] if r["tick"] is not None)
    assert last >= SECONDS * 30 - 1
    for finger in ("left", "right"):
        rows = [r for r in pixel_recording[f"fv/{finger}/markers/image"] if r["tick"] is not None]
        assert [r["tick"] for r in rows] == list(range(0, last + 1, 6))  # 5 Hz of a 30 Hz cell
        assert [r["cell_time"] for r in rows] == pytest.approx([r["tick"] / 30.0 for r in rows])
        assert all(_decoded(r).shape == (240, 320, 3) for r in rows)


def test_recorded_frames_show_the_markers_under_their_arrows(pixel_recording):
    """The frame is in the arrows' pixel axes: the image is darker on the marker origins (dark dots
    on the skin) than around them."""
    origins = np.asarray(pixel_recording["fv/left/markers"][0]["Arrows2D:origins"], float)
    grey = cv2.cvtColor(_decoded(pixel_recording["fv/left/markers/image"][-1]), cv2.COLOR_BGR2GRAY).astype(float)
    x, y = np.round(origins).astype(int).T
    on_markers = grey[y, x].mean()
    beside = grey[np.clip(y + 12, 0, 239), np.clip(x + 12, 0, 319)].mean()  # half-way to the next marker
    assert on_markers < beside - 20


@pytest.mark.parametrize("perception, hz", [("signals", 5.0), ("pixels", 0.0)])
def test_no_images_without_a_camera_or_at_rate_zero(tmp_path, perception, hz):
    recording = _recorded(tmp_path, perception, hz)
    assert "fv/left/markers" in recording and not any(e.endswith("/image") for e in recording)


class _RenderedCamera:
    """A stand-in for a real camera (`OpenCvCamera.read`): rendered FingerVision frames, stamped."""

    def __init__(self, name: str, clock, seed: int):
        from drivers.sim.models.fingervision_model import SensorModel
        from drivers.sim.models.synthetic_camera import SyntheticFingerVision

        self.name, self.clock, self.last_error = name, clock, None
        self.camera = SyntheticFingerVision(SensorModel(name).origin, seed=seed)
        self.sent: list[np.ndarray] = []

    def read(self) -> tuple[np.ndarray, float]:
        self.sent.append(self.camera.render().image)
        return self.sent[-1], self.clock.now()

    def corrupt_frames(self) -> tuple[int, str]:
        return 0, ""


def test_a_real_cell_perception_source_offers_the_frames_it_processed():
    from drivers.camera_frames import frames_of
    from drivers.clock import SimClock
    from drivers.hardware.camera_sense import fingervision_sense
    from perception.config import load_config

    clock = SimClock(1.0 / 30.0)
    cameras = {f: _RenderedCamera(f, clock, i) for i, f in enumerate(("left", "right"))}
    sense = fingervision_sense(cameras, clock, load_config("fast", camera_fps=30.0), {}, 1.0, 5.0)
    for _ in range(3):
        clock.advance()
        states = sense()
    jpegs = frames_of(sense).jpegs(85)
    for finger, camera in cameras.items():
        jpeg, stamp = jpegs[finger]
        assert jpeg == cv2.imencode(".jpg", camera.sent[-1], [cv2.IMWRITE_JPEG_QUALITY, 85])[1].tobytes()
        assert stamp == states[finger].stamp == clock.now()
