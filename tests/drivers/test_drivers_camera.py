"""OpenCV cameras: a video file, an MJPEG URL that drops, two cameras at once, a missing device."""

from __future__ import annotations

import time

import cv2
import numpy as np
import pytest
from drivers_testkit import DEADLINE, next_host, wait_until

from drivers.emulators.mjpeg import MjpegServer, synthetic_frame
from drivers.hardware.camera import CameraConfig, OpenCvCamera


@pytest.fixture
def video(tmp_path):
    path = tmp_path / "fingertip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 100.0, (160, 120))
    for i in range(20):
        writer.write(synthetic_frame(i, (160, 120)))
    writer.release()
    return path


@pytest.fixture
def mjpeg():
    servers = []

    def start(**kwargs) -> MjpegServer:
        servers.append(MjpegServer(next_host(), 0, size=(160, 120), **kwargs).start())
        return servers[-1]

    yield start
    for s in servers:
        s.close()


def read_until_ended(cam: OpenCvCamera, timeout: float) -> list[tuple[np.ndarray, float]]:
    """Poll `read()` like a tick loop would, until the file has ended and nothing is left."""
    got = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        frame = cam.read()
        if frame is not None:
            got.append(frame)
        elif cam.ended:
            break
        time.sleep(0.002)
    return got


def test_video_file_plays_once_with_increasing_stamps(video, clock):
    cam = OpenCvCamera("left", CameraConfig(str(video)), clock)
    try:
        frames = read_until_ended(cam, DEADLINE)
        assert cam.ended and cam.frames == 20 and len(frames) >= 10
        stamps = [t for _, t in frames]
        assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)
        assert frames[0][0].shape == (120, 160, 3)
        assert cam.read() is None  # nothing new after the end
    finally:
        cam.close()


def test_looping_video_file_keeps_delivering(video, clock):
    cam = OpenCvCamera("left", CameraConfig(str(video), loop=True), clock)
    try:
        assert wait_until(lambda: cam.frames > 30, DEADLINE) and not cam.ended
    finally:
        cam.close()


def test_mjpeg_url_reopens_after_the_stream_drops(mjpeg, clock):
    server = mjpeg(fps=100.0, drop_after=10)
    cam = OpenCvCamera("left", CameraConfig(server.url, reopen_after=0.05), clock)
    try:
        assert wait_until(lambda: cam.frames > 25, DEADLINE), cam.last_error
        assert cam.reopens >= 2 and server.connections >= 3
        frame, _ = cam.read()
        assert frame.shape == (120, 160, 3)
    finally:
        cam.close()


def test_two_cameras_stream_at_once(mjpeg, clock):
    left_srv, right_srv = mjpeg(fps=60.0), mjpeg(fps=60.0)
    opened = clock.now()
    cams = {f: OpenCvCamera(f, CameraConfig(s.url), clock) for f, s in (("left", left_srv), ("right", right_srv))}
    try:
        assert wait_until(lambda: all(c.frames >= 20 for c in cams.values()), DEADLINE)
        left, right = cams["left"].read(), cams["right"].read()
        assert left is not None and right is not None
        assert opened <= left[1] <= clock.now() and opened <= right[1] <= clock.now()  # both stamped on the cell clock
    finally:
        for c in cams.values():
            c.close()


def test_missing_device_reports_and_keeps_retrying(clock):
    cam = OpenCvCamera("left", CameraConfig(57, reopen_after=0.05), clock)
    try:
        assert not cam.wait_for_frame(0.3)
        assert wait_until(lambda: cam.last_error is not None, DEADLINE)  # the capture thread tried
        assert "cannot open device 57" in cam.last_error
        assert cam.read() is None
    finally:
        cam.close()


def test_missing_video_file_is_an_error(tmp_path, clock):
    with pytest.raises(FileNotFoundError, match="no video file"):
        OpenCvCamera("left", CameraConfig(str(tmp_path / "none.avi")), clock)
