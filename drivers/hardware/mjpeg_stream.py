"""An MJPEG-over-HTTP stream (multipart/x-mixed-replace, as IP cameras and mjpg-streamer serve it)
read part by part, each JPEG checked whole before it is decoded.

OpenCV's FFmpeg backend hides a truncated or corrupt JPEG: the decoder conceals the missing part
with the last good pixels and `read()` reports success, so half an image can stay frozen while the
other half lives. Here a part must declare its length and deliver all of it, start with the JPEG
start-of-image marker and end with the end-of-image marker, and decode at the expected size;
otherwise it is a `CorruptFrame` naming what is wrong, and the camera reports it.
"""

from __future__ import annotations

import http.client
import urllib.request
from email.message import Message

import cv2
import numpy as np

from drivers.protocols import DriverFault

SOI, EOI = b"\xff\xd8", b"\xff\xd9"
MAX_PART = 16 * 1024 * 1024  # bytes: no camera frame is larger; a bigger Content-Length is corrupt
MAX_HEADER_LINES = 32


class CorruptFrame(DriverFault):
    """One part of the stream is not a whole JPEG; the stream itself goes on."""


def is_mjpeg_url(source: str) -> bool:
    """Whether `source` is an http(s) URL, which cameras serve as MJPEG."""
    return source.startswith(("http://", "https://"))


class MjpegStream:
    """One open MJPEG stream; `read()` returns the next image (BGR), raises `CorruptFrame` for a part
    that is not a whole JPEG, and returns None when the stream ended or broke."""

    def __init__(self, url: str, timeout: float):
        try:
            self._response = urllib.request.urlopen(url, timeout=timeout)
        except (OSError, http.client.HTTPException) as exc:
            raise DriverFault(f"cannot open MJPEG stream {url}: {exc}") from None
        header = Message()
        header["content-type"] = self._response.headers.get("Content-Type", "")
        boundary = header.get_param("boundary")
        if header.get_content_type() != "multipart/x-mixed-replace" or not isinstance(boundary, str):
            self._response.close()
            raise DriverFault(f"{url} is not an MJPEG stream (Content-Type {header['content-type']!r}, "
                              "expected multipart/x-mixed-replace with a boundary)")
        self._boundary = b"--" + boundary.strip('"').encode()
        self.url = url

    def read(self) -> np.ndarray | None:
        try:
            length = self._part_length()
            if length is None:
                return None
            data = self._response.read(length)
        except (OSError, http.client.HTTPException, ValueError):
            return None
        if len(data) < length:
            return None  # the connection ended inside a part
        return decode_whole(data)

    def _part_length(self) -> int | None:
        """Skip to the next part's headers and return its Content-Length, None at the end."""
        line = self._response.readline()
        while line and line.strip() != self._boundary:
            if line.strip() == self._boundary + b"--":
                return None
            line = self._response.readline()
        if not line:
            return None
        length = None
        for _ in range(MAX_HEADER_LINES):
            line = self._response.readline()
            if not line or not line.strip():
                break
            name, _, value = line.decode("latin-1").partition(":")
            if name.strip().lower() == "content-length":
                length = int(value.strip())
        if length is None or not 0 < length <= MAX_PART:
            raise CorruptFrame(f"MJPEG part without a usable Content-Length ({length!r})")
        return length

    def release(self) -> None:
        self._response.close()


def decode_whole(data: bytes) -> np.ndarray:
    """The BGR image of JPEG bytes that hold a whole image, or `CorruptFrame` saying what is wrong."""
    if not data.startswith(SOI):
        raise CorruptFrame("not a JPEG (no start-of-image marker)")
    if not data.rstrip(b"\r\n").endswith(EOI):
        raise CorruptFrame(f"truncated JPEG ({len(data)} bytes, no end-of-image marker)")
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        raise CorruptFrame(f"JPEG of {len(data)} bytes that does not decode")
    return image
