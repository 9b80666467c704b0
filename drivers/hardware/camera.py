"""The Camera protocol on OpenCV capture: a device index (e.g. a FingerVision USB camera), a video
file, or an MJPEG/RTSP URL.

Each camera runs its own capture thread that keeps only the newest frame with its cell-clock
stamp, so `read()` never blocks a tick and several cameras capture at once. When a stream drops,
the thread releases it and reopens it every `reopen_after` seconds until it comes back. An
http(s) URL is read as MJPEG by `mjpeg_stream`, which checks every JPEG whole: a truncated or
corrupt frame is counted and reported (`corrupt_frames`), never handed out concealed.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from drivers.hardware.mjpeg_stream import CorruptFrame, MjpegStream, is_mjpeg_url
from drivers.protocols import Clock, DriverFault

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CameraConfig:
    """One entry of the cell file's `cameras:` section."""

    source: int | str  # device index, video file path, or http(s):// / rtsp:// URL
    width: int | None = None  # requested capture size (devices only)
    height: int | None = None
    fps: float | None = None  # requested rate (devices); playback rate override (files)
    loop: bool = False  # video files: start again at the end instead of ending
    reopen_after: float = 1.0  # s between attempts to reopen a dropped stream
    open_timeout: float = 3.0  # s allowed for opening a URL, and for one read on it

    @property
    def kind(self) -> str:
        if isinstance(self.source, int) or str(self.source).isdigit():
            return "device"
        return "url" if "://" in str(self.source) else "file"


class OpenCvCamera:
    """A Camera backed by cv2.VideoCapture in a background thread."""

    def __init__(self, name: str, config: CameraConfig, clock: Clock):
        self.name, self.config, self.clock = name, config, clock
        if config.kind == "file" and not Path(config.source).exists():
            raise FileNotFoundError(f"camera {name}: no video file {config.source}")
        self._lock = threading.Lock()
        self._frame: tuple[np.ndarray, float] | None = None
        self._seq = 0  # frames captured
        self._returned = 0  # seq of the last frame handed out by read()
        self.reopens = 0
        self._corrupt = 0  # corrupt frames since the last `corrupt_frames()` call
        self._corrupt_reason = ""
        self.ended = False  # a video file without `loop` played to its end
        self.last_error: str | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"camera-{name}", daemon=True)
        self._thread.start()

    # --- Camera protocol ----------------------------------------------------------------------
    def read(self) -> tuple[np.ndarray, float] | None:
        with self._lock:
            if self._frame is None or self._seq == self._returned:
                return None
            self._returned = self._seq
            return self._frame

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=self.config.open_timeout + 1.0)

    def corrupt_frames(self) -> tuple[int, str]:
        """How many frames arrived corrupt (truncated, not a JPEG, undecodable) since the last call,
        and why the last of them was; (0, "") when none."""
        with self._lock:
            got, self._corrupt, self._corrupt_reason = (self._corrupt, self._corrupt_reason), 0, ""
        return got

    # --- status -------------------------------------------------------------------------------
    @property
    def frames(self) -> int:
        """Frames captured so far."""
        return self._seq

    def wait_for_frame(self, timeout: float) -> bool:
        """Block up to `timeout` s for a first frame (for checks at start-up, not for ticks)."""
        deadline = time.monotonic() + timeout
        while self._seq == 0 and time.monotonic() < deadline and not self.ended:
            time.sleep(0.01)
        return self._seq > 0

    # --- capture thread -----------------------------------------------------------------------
    def _open(self) -> cv2.VideoCapture | MjpegStream | None:
        c = self.config
        if c.kind == "url" and is_mjpeg_url(str(c.source)):
            try:
                stream = MjpegStream(str(c.source), c.open_timeout)
            except DriverFault as exc:
                self.last_error = f"camera {self.name}: {exc}"
                return None
            self.last_error = None
            return stream
        if c.kind == "url":
            ms = int(c.open_timeout * 1000)
            cap = cv2.VideoCapture(str(c.source), cv2.CAP_FFMPEG,
                                   [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, ms, cv2.CAP_PROP_READ_TIMEOUT_MSEC, ms])
        elif c.kind == "device":
            cap = cv2.VideoCapture(int(c.source))
            for prop, value in ((cv2.CAP_PROP_FRAME_WIDTH, c.width), (cv2.CAP_PROP_FRAME_HEIGHT, c.height),
                                (cv2.CAP_PROP_FPS, c.fps)):
                if value:
                    cap.set(prop, value)
        else:
            cap = cv2.VideoCapture(str(c.source))
        if cap.isOpened():
            self.last_error = None
            return cap
        cap.release()
        self.last_error = f"camera {self.name}: cannot open {c.kind} {c.source}"
        return None

    def _run(self) -> None:
        cap: cv2.VideoCapture | None = None
        playback = 0.0
        next_at = time.monotonic()
        while not self._stop.is_set():
            if cap is None:
                cap = self._open()
                if cap is None:
                    self._stop.wait(self.config.reopen_after)
                    continue
                playback = self._playback_period(cap)
            try:
                ok, frame = _next_frame(cap)
            except CorruptFrame as exc:
                with self._lock:
                    self._corrupt, self._corrupt_reason = self._corrupt + 1, str(exc)
                continue
            if not ok:
                if self.config.kind == "file" and self.config.loop and self._seq:
                    cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
                    continue
                cap.release()
                cap = None
                if self.config.kind == "file":
                    self.ended = True
                    return
                self.reopens += 1
                self.last_error = f"camera {self.name}: stream dropped, reopening"
                log.warning("%s", self.last_error)
                self._stop.wait(self.config.reopen_after)
                continue
            stamp = self.clock.now()
            with self._lock:
                self._frame, self._seq = (frame, stamp), self._seq + 1
            if playback:  # files play at their own rate, not as fast as they decode
                next_at = max(next_at + playback, time.monotonic() - playback)
                self._stop.wait(max(0.0, next_at - time.monotonic()))
        if cap is not None:
            cap.release()

    def _playback_period(self, cap: cv2.VideoCapture | MjpegStream) -> float:
        if self.config.kind != "file":
            return 0.0
        fps = self.config.fps or cap.get(cv2.CAP_PROP_FPS) or 30.0
        return 1.0 / fps


def _next_frame(cap: cv2.VideoCapture | MjpegStream) -> tuple[bool, np.ndarray | None]:
    """(True, image) or (False, None) when the source ended or broke; CorruptFrame from an MJPEG
    stream whose next part is not a whole JPEG."""
    if isinstance(cap, MjpegStream):
        frame = cap.read()
        return frame is not None, frame
    return cap.read()
