"""The commands that show what a sensor or a run saw: `fvtree view` (replay a run's recording in the
Rerun viewer) and `fvtree sensor` (set up a FingerVision skin on a live or recorded camera)."""

from __future__ import annotations

from pathlib import Path

from assembly.cli.args import POSITIVE_INT, Subparsers


def add_commands(sub: Subparsers) -> None:
    """`fvtree view` and `fvtree sensor`."""
    vw = sub.add_parser("view", help="replay a run's recording in the Rerun viewer (web, on 127.0.0.1)")
    vw.add_argument("run_dir", metavar="RUN_DIR")
    vw.add_argument("--native", action="store_true", help="open the native viewer instead (needs a display)")
    vw.add_argument("--port", type=POSITIVE_INT, default=9876, help="gRPC port of the viewer server")
    vw.add_argument("--web-port", type=POSITIVE_INT, default=9090, help="port of the web viewer page")
    vw.set_defaults(func=cmd_view)

    sn = sub.add_parser("sensor", help="set up a FingerVision skin: live image, markers, calibration, health, "
                                       "wrench; saves the marker map")
    sn.add_argument("source", help="camera device index, video file, or MJPEG/RTSP URL")
    sn.add_argument("--map", default="marker_map.yaml", help="marker map file to write (default: marker_map.yaml)")
    sn.add_argument("--preset", default="fast", help="perception preset (default: fast)")
    sn.add_argument("--finger", choices=("left", "right"), default="right")
    sn.add_argument("--frames", type=POSITIVE_INT, default=None, help="stop after this many frames")
    sn.add_argument("--save", default=None, metavar="FILE.rrd", help="also write a recording")
    sn.add_argument("--image-every", type=POSITIVE_INT, default=1, metavar="N", help="send every N-th image")
    sn.add_argument("--no-view", action="store_true", help="no web viewer (with --save: record only)")
    sn.set_defaults(func=cmd_sensor)


def cmd_view(args) -> int:
    from assembly.observe.replay import view

    return view(Path(args.run_dir), web=not args.native, web_port=args.web_port, grpc_port=args.port)


def cmd_sensor(args) -> int:
    from assembly.observe.sensor_view import sensor_view

    seen = sensor_view(args.source, Path(args.map), args.preset, args.finger, args.frames,
                       Path(args.save) if args.save else None, not args.no_view, args.image_every)
    print(f"{seen['frames']} frames, {seen['unhealthy']} unhealthy, {seen.get('markers', 0)} markers in the map")
    return 0
