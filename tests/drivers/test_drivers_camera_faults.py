"""Bad frames through the MJPEG camera emulator mark the fingertip unhealthy, with the reason: a
camera sending half of each JPEG (before: OpenCV's decoder concealed the missing half with the last
good pixels and the run ended SUCCESS), one whose lower half is stuck in otherwise whole frames, and
one streaming another size than the sensor was calibrated at. The other fingertip stays healthy."""

from __future__ import annotations

import time

import pytest
from drivers_testkit import DEADLINE, next_host

from drivers.clock import WallClock
from drivers.emulators.mjpeg import MjpegServer, fingervision_renderer
from drivers.hardware.camera import CameraConfig, OpenCvCamera
from drivers.hardware.camera_sense import fingervision_sense
from drivers.hardware.mjpeg_stream import CorruptFrame, decode_whole
from perception.config import load_config
from perception.fingervision import FingerVision

SIZE = (320, 240)
FAULT_FROM = 20  # frames: good ones first


def calibrated():
    """The marker map of the emulator's fingertip at rest, at SIZE."""
    render = fingervision_renderer(SIZE)
    return FingerVision(load_config("fast"), "right").calibrate([render(i, SIZE) for i in range(10)])


@pytest.fixture
def cell():
    """Start two fingertip cameras ({finger: MjpegServer options}) and their perception source."""
    servers, cameras = [], []

    def start(**faults):
        clock = WallClock(1 / 30)
        for finger in ("left", "right"):
            options = faults if finger == "right" else {}
            size = options.pop("size", SIZE)
            servers.append(MjpegServer(next_host(), 0, fps=60.0, size=size, pattern="fingervision", **options).start())
            cameras.append(OpenCvCamera(finger, CameraConfig(servers[-1].url), clock))
        named = dict(zip(("left", "right"), cameras))
        maps = {finger: calibrated() for finger in named}  # calibrated at SIZE on the emulator's frames at rest
        return fingervision_sense(named, clock, load_config("fast", camera_fps=60.0), maps, 5.0, DEADLINE)

    yield start
    for camera in cameras:
        camera.close()
    for server in servers:
        server.close()


def unhealthy_for(sense, reason: str) -> tuple[str, int]:
    """Tick at 30 Hz until the right fingertip is unhealthy for `reason`: (its reason, the count of
    ticks from the second on where the left one was unhealthy; the first tick may find no frame yet)."""
    deadline, ticks, left_unhealthy = time.monotonic() + DEADLINE, 0, 0
    while time.monotonic() < deadline:
        states = sense()
        ticks += 1
        left_unhealthy += ticks > 1 and not states["left"].healthy
        if reason in states["right"].health_reason and not states["right"].healthy:
            return states["right"].health_reason, left_unhealthy
        time.sleep(1 / 30)
    raise AssertionError(f"the right fingertip was never unhealthy for {reason!r} in {DEADLINE} s")


def test_a_camera_sending_half_of_each_jpeg_is_unhealthy(cell):
    reason, left_unhealthy = unhealthy_for(cell(truncate_after=FAULT_FROM), "truncated JPEG")
    assert "corrupt frame" in reason and left_unhealthy == 0


def test_a_camera_whose_lower_half_is_stuck_is_unhealthy(cell):
    _, left_unhealthy = unhealthy_for(cell(freeze_below_after=FAULT_FROM), "part of the image frozen")
    assert left_unhealthy == 0


def test_a_camera_streaming_another_size_than_calibrated_is_unhealthy(cell):
    _, left_unhealthy = unhealthy_for(cell(size=(640, 480)),
                                      "frame is 640x480 but the sensor was calibrated at 320x240")
    assert left_unhealthy == 0


@pytest.mark.parametrize("data, why", [(b"GIF89a", "not a JPEG"), (b"\xff\xd8\xff\xe0" + b"\0" * 64, "truncated JPEG"),
                                       (b"\xff\xd8" + b"\x13" * 64 + b"\xff\xd9", "does not decode")])
def test_parts_that_are_not_a_whole_jpeg_are_named(data, why):
    with pytest.raises(CorruptFrame, match=why):
        decode_whole(data)
