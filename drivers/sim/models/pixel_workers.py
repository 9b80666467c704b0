"""Pixel mode's two fingertips processed at the same time, as a real FingerVision rig processes each
camera on its own: one finger's renderer and pipeline run in a worker process while the main process
does the other's (faster than a worker for each: the main process would only wait, and the messages
double). A finger's frame costs ~2 ms; on two free cores a tick costs about one frame instead of two
(3.3 instead of 4.6 ms a tick on fixed frames); on a machine other programs load it gains less.

A tick sends a worker only what its frame needs (marker positions and sizes, the object, its slip
shift, the stamp) and gets back the TactileState: the same as the in-process path's, bit for bit.
Both travel as flat bytes (`pixel_messages`: ~1 and ~2.4 kB, ~20 us a tick to write and read
against ~120 us as pickles). The camera image stays in the worker: when the run's recording takes
the frames (a few times a second: `WorkerFrames.jpegs`), the main process asks the worker for the
JPEG of its frame, encodes its own finger's meanwhile, then takes the worker's (~13 kB) from the
pipe. The encoding (~0.2 ms a frame) so moves off the main process, which sets the pace, to the
worker, which has idle time each tick.

Workers start from a clean process (`forkserver`, else `spawn`: the main process may hold threads),
ignore Ctrl-C (the main process halts the run and closes the cell, which stops them) and leave when
the main process is gone. A worker that dies, raises or does not answer within `REPLY_TIMEOUT`
gives unhealthy states naming its camera from then on, never a hang.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
from collections.abc import Callable, Collection, Mapping
from multiprocessing.connection import Connection
from typing import Any, Protocol

import numpy as np

from drivers.camera_frames import LatestFrames, jpeg_of
from drivers.protocols import DriverFault
from drivers.sim.models.pixel_messages import (
    StateDecoder,
    StateEncoder,
    decode_frame,
    decode_jpeg,
    encode_frame,
    encode_jpeg,
)
from perception.state import FINGERS, ObjectInfo, TactileState

# Fingers processed in a worker when the fingers run in parallel; the others stay in the main process.
WORKER_FINGERS = ("right",)
REPLY_TIMEOUT = 10.0  # s a tick waits for a worker's state: generous for a loaded machine
START_TIMEOUT = 120.0  # s for a worker to start, import the pipeline and calibrate
CLOSE_TIMEOUT = 5.0  # s a closing worker gets to leave before it is terminated
# Each message starts with its kind: a frame to process, a request for the JPEG of the newest frame
# (its quality in one byte), the end; the worker answers ready, a state, a JPEG or an error.
FRAME, JPEG, STOP, READY, STATE, ERROR = b"f", b"j", b"q", b"r", b"s", b"e"

Frame = tuple  # (position (N, 2), size (N,), ObjectInfo | None, slip shift px, stamp s)


class FingerFrames(Protocol):
    """What processes one finger's frames: renders the frame and puts it through the pipeline."""

    def process(self, position: np.ndarray, size: np.ndarray, obj: ObjectInfo | None, shift: float,
                stamp: float) -> tuple[TactileState, np.ndarray]: ...


# Builds a finger's processor from its picklable description (a module-level class, so a worker can
# import it: `synthetic_camera.PixelFinger` of a `FingerRig`).
Build = Callable[[Any], FingerFrames]


def parallel_by_default() -> bool:
    """Fingers in parallel when this process may use a core for each."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return cores >= 2


def _context() -> multiprocessing.context.BaseContext:
    """A start method that does not copy the main process's threads: forkserver (with the pipeline
    imported once in the server, so a worker starts in milliseconds), else spawn."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([__name__, "drivers.sim.models.synthetic_camera", "perception.fingervision"])
    return context


def _serve(conn: Connection, build: Build, rig: Any) -> None:
    """A worker's life: build and calibrate the finger, then answer frames and JPEG requests until
    told to stop or the main process is gone."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the main process's to handle
    image, stamp = None, 0.0
    encoder = StateEncoder()
    try:
        finger = build(rig)
        conn.send_bytes(READY)
        while True:
            try:
                message = conn.recv_bytes()
            except (EOFError, OSError):  # the main process is gone
                return
            if message[:1] == FRAME:
                state, image = finger.process(*decode_frame(memoryview(message)[1:]))
                stamp = state.stamp
                conn.send_bytes(STATE + encoder.encode(state))
            elif message[:1] == JPEG:
                jpeg = jpeg_of(image, message[1]) if image is not None else None
                conn.send_bytes(JPEG + encode_jpeg(jpeg, stamp))
            else:
                return
    except Exception as exc:  # noqa: BLE001 - any failure goes to the main process, which marks the finger unhealthy
        try:
            conn.send_bytes(ERROR + f"{type(exc).__name__}: {exc}".encode())
        except OSError:
            pass


class FingerWorker:
    """The main process's end of one finger's worker."""

    def __init__(self, context: multiprocessing.context.BaseContext, finger: str, build: Build, rig: Any):
        self.finger = finger
        self._conn, child = context.Pipe()
        self.process = context.Process(target=_serve, args=(child, build, rig), name=f"pixel worker {finger}",
                                       daemon=True)
        self.process.start()
        child.close()
        self.failure = ""  # why the worker no longer answers ("" while it works)
        self._states = StateDecoder(finger)

    def wait_ready(self, timeout: float) -> None:
        """Block until the worker has calibrated its finger, or raise DriverFault saying why not."""
        reply = self._reply(timeout)
        if reply is None or reply[:1] != READY:
            self.close()
            raise DriverFault(f"{self.failure or reply!r} while starting - a script that builds a pixel-mode cell "
                              "needs the `if __name__ == '__main__':` guard; or run pixel mode without workers: "
                              "`pixel_workers: false` in the cell file")

    def submit(self, frame: Frame) -> None:
        """Send a frame to process (nothing once the worker has failed)."""
        self._send(FRAME + encode_frame(*frame), "a frame")

    def state(self, stamp: float) -> TactileState:
        """The state of the frame submitted last, or an unhealthy state naming what went wrong."""
        reply = self._reply(REPLY_TIMEOUT) if not self.failure else None
        if reply is not None and reply[:1] == STATE:
            return self._states.decode(memoryview(reply)[1:])
        return TactileState(self.finger, stamp, healthy=False, health_reason=self.failure)

    def ask_jpeg(self, quality: int) -> bool:
        """Ask for the JPEG (at `quality`, 0-100) of the frame processed last, to collect with `jpeg`
        (the worker encodes it meanwhile); False when it could not be asked (the worker has failed)."""
        return self._send(JPEG + bytes([quality]), "a JPEG request")

    def jpeg(self) -> tuple[bytes, float] | None:
        """The answer to `ask_jpeg`: the JPEG and its stamp (None before the first frame or when the
        worker fails)."""
        reply = self._reply(REPLY_TIMEOUT)
        return decode_jpeg(memoryview(reply)[1:]) if reply is not None and reply[:1] == JPEG else None

    def _send(self, message: bytes, what: str) -> bool:
        """Send `message` (`what` it is, for the failure); False once the worker has failed."""
        if self.failure:
            return False
        try:
            self._conn.send_bytes(message)
        except OSError as exc:
            self._fail(f"could not be sent {what} ({exc})")
            return False
        return True

    def _reply(self, timeout: float) -> bytes | None:
        """The worker's next message; None (and the worker failed) when it dies, raises or times out."""
        try:
            if not self._conn.poll(timeout):
                self._fail(f"did not answer in {timeout:g} s")
                return None
            reply = self._conn.recv_bytes()
        except (EOFError, OSError):
            self.process.join(CLOSE_TIMEOUT)
            self._fail(f"died (exit code {self.process.exitcode})")
            return None
        if reply[:1] == ERROR:
            self._fail(f"raised {reply[1:].decode()}")
            return None
        return reply

    def _fail(self, why: str) -> None:
        """Remember why, and end the worker at once: whatever it still holds is of no use."""
        self.failure = f"camera {self.finger}: the pixel-mode worker (pid {self.process.pid}) {why}"
        self.process.kill()
        self.process.join(CLOSE_TIMEOUT)
        self._conn.close()

    def close(self) -> None:
        """Ask the worker to leave, wait a bounded time, then terminate it."""
        try:
            self._conn.send_bytes(STOP)
        except OSError:
            pass
        self.process.join(CLOSE_TIMEOUT)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(CLOSE_TIMEOUT)
        if self.process.is_alive():  # stopped (SIGSTOP) or ignoring SIGTERM
            self.process.kill()
            self.process.join(CLOSE_TIMEOUT)
        self._conn.close()


class WorkerFrames(LatestFrames):
    """The newest frame of each finger: kept (references) for the fingers processed in this process,
    in their workers for the others (a tick sends no image)."""

    def __init__(self, workers: Mapping[str, FingerWorker]):
        super().__init__()
        self._workers = workers

    def jpegs(self, quality: int) -> dict[str, tuple[bytes, float]]:
        """Finger -> (JPEG bytes, stamp) of each finger's newest frame, in FINGERS order: the workers
        are asked first and encode theirs while this process encodes its own (none from a failed worker)."""
        asked = [worker for worker in self._workers.values() if worker.ask_jpeg(quality)]
        encoded = super().jpegs(quality)
        for worker in asked:
            got = worker.jpeg()
            if got is not None:
                encoded[worker.finger] = got
        return {finger: encoded[finger] for finger in FINGERS if finger in encoded}


class FingerWorkers:
    """Both fingers of pixel mode, each processor made by `build` from the finger's entry of `rigs`: those in
    `remote` in worker processes, the others in this process."""

    def __init__(self, build: Build, rigs: Mapping[str, Any], remote: Collection[str]):
        context = _context() if remote else None
        self._workers = {finger: FingerWorker(context, finger, build, rigs[finger])
                         for finger in FINGERS if finger in remote}
        try:
            self._local = {finger: build(rigs[finger]) for finger in FINGERS if finger not in remote}
            for worker in self._workers.values():  # calibrating meanwhile
                worker.wait_ready(START_TIMEOUT)
        except BaseException:
            self.close()
            raise
        self.frames = WorkerFrames(self._workers)

    @property
    def processes(self) -> dict[str, multiprocessing.process.BaseProcess]:
        """Finger -> its worker process (none for the fingers processed here)."""
        return {finger: worker.process for finger, worker in self._workers.items()}

    def process(self, frames: Mapping[str, Frame]) -> dict[str, TactileState]:
        """Each finger's state of its frame; the workers' frames are processed while this process does its own."""
        for finger, worker in self._workers.items():
            worker.submit(frames[finger])
        states = {}
        for finger, local in self._local.items():
            states[finger], image = local.process(*frames[finger])
            self.frames.keep(finger, image, states[finger].stamp)
        for finger, worker in self._workers.items():
            states[finger] = worker.state(frames[finger][-1])
        return {finger: states[finger] for finger in FINGERS}

    def close(self) -> None:
        """Stop the workers (bounded: each is terminated if it does not leave in time)."""
        for worker in self._workers.values():
            worker.close()
