"""Start every emulator a real-cell file points at (UR controller, Robotiq gripper, MJPEG cameras),
each in its own process, until Ctrl-C:

    python -m drivers.emulators [--cell drivers/cells/emulated.yaml] [--contact-z 0.05]
                                [--object-width 0.04]

Only loopback addresses are served. Then `fvtree check --cell drivers/cells/emulated.yaml`.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path
from urllib.parse import urlparse

from drivers.cell_builders import builder_kind
from drivers.cell_file import CELLS_DIR, read_cell_file
from drivers.emulators.launch import EmulatorProcess
from drivers.hardware.real_cell import parse
from drivers.loopback import is_loopback


def cell_emulators(cell_file: Path, contact_z: float | None = None,
                   object_width: float | None = None) -> list[EmulatorProcess]:
    """The (not yet started) emulator processes for the devices of a `kind: real` cell file."""
    data = read_cell_file(cell_file)
    spec = parse(cell_file, data, shadow=builder_kind(cell_file, data) == "emulated_shadow")
    arm, grip, emulation = spec["arm"], spec["gripper"], spec["emulation"]
    for host in (arm.host, grip.host):
        if not is_loopback(host):
            raise ValueError(f"{cell_file}: {host} is not a loopback address; emulators serve loopback only")
    scale = str(emulation.time_scale)
    ur_args = ["--host", arm.host, "--time-scale", scale, "--backdoor-port", str(emulation.arm_backdoor_port)]
    if contact_z is not None:
        ur_args += ["--contact-z", str(contact_z)]
    gripper_args = ["--host", grip.host, "--port", str(grip.port), "--framer", grip.framing,
                    "--device-id", str(grip.device_id), "--command-address", str(grip.command_address),
                    "--status-address", str(grip.status_address), "--stroke", str(grip.max_width),
                    "--speed-range", *map(str, grip.speed_range), "--force-range", *map(str, grip.force_range),
                    "--pad-stiffness", str(emulation.pad_stiffness),
                    "--time-scale", scale, "--backdoor-port", str(emulation.gripper_backdoor_port)]
    if object_width is not None:
        gripper_args += ["--object-width", str(object_width)]
    procs = [EmulatorProcess("drivers.emulators.ur", ur_args),
             EmulatorProcess("drivers.emulators.robotiq", gripper_args)]
    for cam in spec["cameras"].values():
        url = urlparse(str(cam.source))
        if url.scheme == "http" and is_loopback(url.hostname or ""):
            procs.append(EmulatorProcess("drivers.emulators.mjpeg", [
                "--host", url.hostname, "--port", str(url.port or 80), "--pattern", "fingervision"]))
    return procs


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m drivers.emulators", description=__doc__.split("\n\n")[0])
    p.add_argument("--cell", type=Path, default=CELLS_DIR / "emulated.yaml")
    p.add_argument("--contact-z", type=float, default=None, help="UR contact plane height (m)")
    p.add_argument("--object-width", type=float, default=None, help="object between the fingers (m)")
    args = p.parse_args(argv)
    procs = cell_emulators(args.cell, args.contact_z, args.object_width)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    try:
        for proc in procs:
            proc.start()
            print(f"running {proc.module} {' '.join(proc.args)}", flush=True)
        print("ready (Ctrl-C to stop)", flush=True)
        while not stop.wait(0.5):
            dead = [proc for proc in procs if not proc.alive()]
            if dead:
                print(f"{dead[0].module} exited: {dead[0].errors()}", file=sys.stderr)
                return 1
    finally:
        for proc in reversed(procs):
            proc.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
