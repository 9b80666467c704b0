"""The perception stage of a real cell: each finger's camera through the FingerVision pipeline,
one TactileState per finger per tick. Calibrates at start on frames without contact (or loads
saved marker maps); a camera that stops delivering gives an unhealthy state, never an old one
dressed as new, and a frame that arrived corrupt makes that tick's state unhealthy."""

from __future__ import annotations

import time
from collections.abc import Callable

from drivers.camera_frames import LatestFrames
from drivers.hardware.camera import OpenCvCamera
from drivers.protocols import Clock, DriverFault
from perception.calibration import MarkerMap
from perception.config import FingerVisionConfig
from perception.state import FINGERS, TactileState


def fingervision_sense(cameras: dict[str, OpenCvCamera], clock: Clock, config: FingerVisionConfig,
                       marker_maps: dict[str, MarkerMap], stale_after: float,
                       calibration_timeout: float) -> Callable[[], dict[str, TactileState]]:
    """Build the per-tick perception source with the pipeline `config`: fingers with a saved
    marker map track against it, the others calibrate now (blocking, bounded) on fresh frames."""
    from perception.fingervision import FingerVision

    missing = [f for f in FINGERS if f not in cameras]
    if missing:
        raise DriverFault(f"perception needs a camera per finger; missing: {', '.join(missing)}")
    pipelines = {}
    for finger in FINGERS:
        pipeline = FingerVision(config, finger)
        if finger in marker_maps:
            pipeline.use_marker_map(marker_maps[finger])
        else:
            n = pipeline.config.calibration.n_frames
            pipeline.calibrate(_grab(cameras[finger], n, calibration_timeout))
        pipelines[finger] = pipeline
    last: dict[str, TactileState] = {}

    def sense() -> dict[str, TactileState]:
        now = clock.now()
        for finger in FINGERS:
            got = cameras[finger].read()
            corrupt, broken = cameras[finger].corrupt_frames()
            if got is not None:
                last[finger] = pipelines[finger].process(*got)
                sense.frames.keep(finger, *got)
            elif finger not in last or now - last[finger].stamp > stale_after:
                why = cameras[finger].last_error or "stream stalled"
                last[finger] = TactileState(finger, now, healthy=False, health_reason=(
                    f"camera {finger}: no frame for {stale_after:g} s ({why})"))
            if corrupt:  # a stream that sends broken frames is not trusted, even between good ones
                last[finger] = TactileState(finger, now, healthy=False, health_reason=(
                    f"camera {finger}: {corrupt} corrupt frame{'s' if corrupt > 1 else ''} since the last "
                    f"tick ({broken})"))
        return dict(last)

    sense.frames = LatestFrames()  # for the run's recording
    return sense


def _grab(camera: OpenCvCamera, n: int, timeout: float) -> list:
    """`n` consecutive new frames for calibration, or DriverFault naming the camera."""
    frames = []
    deadline = time.monotonic() + timeout
    while len(frames) < n:
        if time.monotonic() > deadline:
            raise DriverFault(f"camera {camera.name}: only {len(frames)} of {n} calibration frames in "
                              f"{timeout:g} s ({camera.last_error or 'no frames'}) - check the cable "
                              "and the source in the cell file")
        got = camera.read()
        if got is None:
            time.sleep(0.005)
        else:
            frames.append(got[0])
    return frames
