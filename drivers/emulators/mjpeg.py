"""An MJPEG-over-HTTP camera emulator (multipart/x-mixed-replace, like IP cameras and
mjpg-streamer): synthetic frames whose top-left pixel row encodes the frame number.

    python -m drivers.emulators.mjpeg --host 127.0.0.4 --port 8080 [--fps 30]
        [--size 320x240] [--pattern bars|fingervision] [--drop-after N]
        [--truncate-after N] [--freeze-below-after N]

The stream is at http://HOST:PORT/stream.mjpg. `--pattern fingervision` streams rendered
FingerVision frames (markers at rest, no contact) that the perception pipeline can calibrate on.
Faults of real cameras, each from frame N on: `--drop-after N` closes every connection (a flaky
camera; the driver must reopen); `--truncate-after N` sends only the first half of each JPEG (its
Content-Length says so: a camera whose encoder or link cuts frames short); `--freeze-below-after N`
sends whole JPEGs whose lower half stays the image of frame N (a stuck sensor area).
Prints `ready` once it listens.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import cv2
import numpy as np

from drivers.loopback import is_loopback

BOUNDARY = "fvtreeframe"


def synthetic_frame(index: int, size: tuple[int, int]) -> np.ndarray:
    """A BGR test image: a moving bar, and the frame number in the first pixel row (low byte)."""
    w, h = size
    img = np.full((h, w, 3), 40, np.uint8)
    x = (index * 4) % w
    img[:, x:x + 8] = (0, 200, 255)
    img[0, :] = index % 256
    return img


def fingervision_renderer(size: tuple[int, int], seed: int = 0):
    """Frames of a FingerVision sensor at rest, from the simulator's renderer."""
    from drivers.sim.models.fingervision_model import radial_marker_layout
    from drivers.sim.models.synthetic_camera import SyntheticFingerVision

    camera = SyntheticFingerVision(radial_marker_layout(size), 9.0, size, seed=seed)
    return lambda index, _size: camera.render().image


class MjpegServer:
    """A threaded HTTP server streaming synthetic MJPEG frames; usable in-process or via main()."""

    def __init__(self, host: str, port: int, fps: float = 30.0, size: tuple[int, int] = (320, 240),
                 drop_after: int | None = None, pattern: str = "bars", truncate_after: int | None = None,
                 freeze_below_after: int | None = None):
        self.fps, self.size, self.drop_after = fps, size, drop_after
        self.truncate_after, self.freeze_below_after = truncate_after, freeze_below_after
        self.render = fingervision_renderer(size) if pattern == "fingervision" else synthetic_frame
        self.connections = 0
        server = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self):  # http.server's naming
                if self.path != "/stream.mjpg":
                    self.send_error(404, "the stream is at /stream.mjpg")
                    return
                server.connections += 1
                self.send_response(200)
                self.send_header("Content-Type", f"multipart/x-mixed-replace; boundary={BOUNDARY}")
                self.end_headers()
                server.stream(self.wfile)

            def log_message(self, *args):
                pass

        self.httpd = ThreadingHTTPServer((host, port), Handler)
        self.httpd.daemon_threads = True
        self.url = f"http://{host}:{self.httpd.server_address[1]}/stream.mjpg"

    def stream(self, out) -> None:
        """Write frames at `fps` until the client leaves (or `drop_after` frames were sent)."""
        index, next_at, stuck = 0, time.monotonic(), None
        try:
            while self.drop_after is None or index < self.drop_after:
                image = self.render(index, self.size)
                if self.freeze_below_after is not None and index >= self.freeze_below_after:
                    stuck = image[image.shape[0] // 2:].copy() if stuck is None else stuck
                    image[image.shape[0] // 2:] = stuck
                jpg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()
                if self.truncate_after is not None and index >= self.truncate_after:
                    jpg = jpg[:len(jpg) // 2]
                out.write(f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
                          f"Content-Length: {len(jpg)}\r\n\r\n".encode() + jpg + b"\r\n")
                out.flush()
                index += 1
                next_at += 1.0 / self.fps
                time.sleep(max(0.0, next_at - time.monotonic()))
        except (BrokenPipeError, ConnectionResetError):
            pass

    def start(self) -> MjpegServer:
        threading.Thread(target=self.httpd.serve_forever, name="mjpeg", daemon=True).start()
        return self

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m drivers.emulators.mjpeg", description=__doc__.split("\n\n")[0])
    p.add_argument("--host", default="127.0.0.4", help="loopback address to bind")
    p.add_argument("--port", type=int, default=8080)
    p.add_argument("--fps", type=float, default=30.0)
    p.add_argument("--size", default="320x240", help="WIDTHxHEIGHT")
    p.add_argument("--pattern", choices=["bars", "fingervision"], default="bars")
    p.add_argument("--drop-after", type=int, default=None, help="close connections after N frames")
    p.add_argument("--truncate-after", type=int, default=None, help="send half of each JPEG from frame N on")
    p.add_argument("--freeze-below-after", type=int, default=None,
                   help="keep the image's lower half of frame N from then on")
    args = p.parse_args(argv)
    if not is_loopback(args.host):
        p.error("the emulator binds loopback addresses only (127.0.0.0/8, ::1, localhost)")
    w, h = (int(v) for v in args.size.lower().split("x"))
    server = MjpegServer(args.host, args.port, args.fps, (w, h), args.drop_after, args.pattern,
                         args.truncate_after, args.freeze_below_after).start()
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    print("ready", flush=True)
    stop.wait()
    server.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
