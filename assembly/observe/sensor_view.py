"""`fvtree sensor SOURCE`: the view a lab uses when mounting or replacing a FingerVision skin. The
camera (device index, video file or MJPEG/RTSP URL, through the cell's camera driver) is calibrated
on its first frames with the real pipeline, the marker map is saved, and then every frame is shown
in the Rerun viewer: the image with the detected markers (green tracked, red lost) and their
displacement arrows, the calibration, the health flags, force and torque."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from assembly.observe.replay import Viewer, start_viewer
from drivers.clock import WallClock
from drivers.hardware.camera import CameraConfig, OpenCvCamera
from fvfiles.errors import FvtreeError
from perception.calibration import MarkerMap
from perception.fingervision import FingerVision
from perception.state import TactileState

VALID, LOST = (60, 180, 75, 255), (220, 50, 47, 255)
JPEG_QUALITY = 80  # images go out JPEG-compressed: ~15 kB instead of 230 kB a 320x240 frame
ARROW_GAIN = 5.0  # displacement arrows drawn this many times longer than the displacement


def sensor_layout() -> rrb.Blueprint:
    """Image with markers on the left; calibration, health and the wrench traces on the right."""
    return rrb.Blueprint(rrb.Horizontal(
        rrb.Spatial2DView(origin="sensor/image", name="image, markers"),
        rrb.Vertical(rrb.TextDocumentView(origin="sensor/calibration", name="calibration"),
                     rrb.TextLogView(origin="sensor/health", name="health"),
                     rrb.TimeSeriesView(origin="sensor/force", name="force"),
                     rrb.TimeSeriesView(origin="sensor/torque", name="torque"),
                     rrb.TimeSeriesView(origin="sensor/tracked", name="markers tracked")),
        column_shares=[3, 2]), collapse_panels=True)


def parse_source(text: str) -> int | str:
    """A device index stays a number; a file must exist; anything with :// is a URL."""
    if text.isdigit():
        return int(text)
    if "://" not in text and not Path(text).is_file():
        raise FvtreeError("no such video file (give a device index, a video file or an http(s)/rtsp URL)", text)
    return text


def _grab(camera: OpenCvCamera, timeout: float) -> tuple[np.ndarray, float] | None:
    """The next frame, or None when the source ended or gave nothing for `timeout` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = camera.read()
        if got is not None:
            return got
        if camera.ended:
            return None
        time.sleep(0.002)
    return None


def sensor_view(source: str, marker_map: Path, preset: str = "fast", finger: str = "right",
                frames: int | None = None, save: Path | None = None, view: bool = True,
                image_every: int = 1, timeout: float = 10.0, say=print) -> dict:
    """Calibrate on the source's first frames, save the marker map at `marker_map`, then show up to
    `frames` frames (None: until the source ends or Ctrl-C) in the web viewer (`view`) and/or a
    recording `save`; every `image_every`-th image is sent. Returns what was seen."""
    pipeline = FingerVision(preset, finger)
    clock = WallClock(1.0 / pipeline.config.camera_fps)
    camera = OpenCvCamera("sensor", CameraConfig(parse_source(source)), clock)
    viewer = start_viewer([]) if view else None
    stream = _open_stream(save, viewer)
    if viewer:
        say(f"sensor view: open {viewer.page}  (Ctrl-C to stop)")
    seen = {"frames": 0, "unhealthy": 0}
    try:
        found = _calibrate(pipeline, camera, source, marker_map, timeout, say)
        _log_calibration(stream, found, pipeline.config.calibration.n_frames, marker_map)
        _show_frames(stream, pipeline, camera, frames, image_every, timeout, seen)
        seen["markers"] = len(found)
        if viewer and frames is None:
            say(f"the source ended after {seen['frames']} frames; the view stays until Ctrl-C")
            viewer.process.wait()
    except KeyboardInterrupt:
        pass
    finally:
        _close(camera, stream, viewer)
    return seen


def _open_stream(save: Path | None, viewer: Viewer | None) -> rr.RecordingStream:
    """A recording stream to the file `save` and/or the viewer, laid out as the sensor view and timed
    only by the frames' own timelines."""
    stream = rr.RecordingStream("fvtree-sensor")
    sinks = ([rr.FileSink(str(save))] if save else []) + ([rr.GrpcSink(viewer.grpc)] if viewer else [])
    stream.set_sinks(*sinks, default_blueprint=sensor_layout())
    stream.set_log_time_enabled(False)
    stream.set_log_tick_enabled(False)
    return stream


def _calibrate(pipeline: FingerVision, camera: OpenCvCamera, source: str, marker_map: Path, timeout: float,
               say) -> MarkerMap:
    """Calibrate the pipeline on the camera's first frames and save the marker map at `marker_map`
    (FvtreeError, naming `source`, if the camera gives too few frames)."""
    needed = pipeline.config.calibration.n_frames
    calibration: list[np.ndarray] = []
    while len(calibration) < needed:
        got = _grab(camera, timeout)
        if got is None:
            raise FvtreeError(f"only {len(calibration)} frames for the calibration (needs "
                              f"{needed}): {camera.last_error or 'the source ended'}", source)
        calibration.append(got[0])
    found = pipeline.calibrate(calibration)
    found.save(marker_map)
    say(f"calibrated {len(found)} markers on {len(calibration)} frames; marker map saved to {marker_map}")
    return found


def _log_calibration(stream: rr.RecordingStream, found: MarkerMap, n_frames: int, marker_map: Path) -> None:
    """What stays the same over the view: the calibration's summary, the markers' rest positions and
    the names of the wrench series."""
    stream.log("sensor/calibration", rr.TextDocument(
        f"{len(found)} markers, image {found.image_size[0]}x{found.image_size[1]} px, "
        f"median diameter {float(np.median(found.size)):.1f} px, calibrated on {n_frames} frames; "
        f"marker map: {marker_map}"), static=True)
    stream.log("sensor/image/origins", rr.Points2D(found.origin, radii=0.8, colors=[(255, 255, 255, 120)]),
               static=True)
    for name in ("force", "torque"):
        stream.log(f"sensor/{name}", rr.SeriesLines(names=["x", "y", "z"]), static=True)


def _show_frames(stream: rr.RecordingStream, pipeline: FingerVision, camera: OpenCvCamera, frames: int | None,
                 image_every: int, timeout: float, seen: dict) -> None:
    """Process and log the camera's frames until `frames` were shown (None: until the source ends),
    counting them and the unhealthy ones in `seen` as they go (so Ctrl-C keeps the counts)."""
    healthy = None
    while frames is None or seen["frames"] < frames:
        got = _grab(camera, timeout)
        if got is None:
            break
        frame, stamp = got
        state = pipeline.process(frame, stamp)
        stream.set_time("frame", sequence=seen["frames"])
        stream.set_time("cell_time", duration=stamp)
        if seen["frames"] % image_every == 0:
            stream.log("sensor/image", rr.Image(frame, color_model="BGR").compress(jpeg_quality=JPEG_QUALITY))
        _log_state(stream, state)
        if state.healthy != healthy:
            healthy = state.healthy
            _log_health(stream, state)
        seen["frames"] += 1
        seen["unhealthy"] += not state.healthy


def _close(camera: OpenCvCamera, stream: rr.RecordingStream, viewer: Viewer | None) -> None:
    """Release the camera, finish the recording and stop the viewer, whatever ended the view."""
    camera.close()
    stream.flush()
    stream.disconnect()
    if viewer:
        viewer.stop()


def _log_health(stream: rr.RecordingStream, state: TactileState) -> None:
    """A line in the health log, logged when the sensor turns healthy or unhealthy."""
    stream.log("sensor/health", rr.TextLog("healthy" if state.healthy else f"unhealthy: {state.health_reason}",
                                           level="INFO" if state.healthy else "WARN"))


def _log_state(stream: rr.RecordingStream, state: TactileState) -> None:
    """One frame's markers (green tracked, red lost) with their displacement arrows, force, torque and
    the share of markers tracked."""
    m = state.markers
    colours = np.where(m.valid[:, None], VALID, LOST).astype(np.uint8)
    stream.log("sensor/image/markers", rr.Points2D(m.position, radii=m.size / 2.0, colors=colours))
    stream.log("sensor/image/displacement", rr.Arrows2D(origins=m.origin, vectors=(m.position - m.origin) * ARROW_GAIN,
                                                        colors=colours))
    stream.log("sensor/force", rr.Scalars(state.force))
    stream.log("sensor/torque", rr.Scalars(state.torque))
    stream.log("sensor/tracked", rr.Scalars(float(m.valid.mean()) if len(m.valid) else 0.0))
