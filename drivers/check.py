"""`fvtree check --cell FILE`: connect to each device of a cell, read its state, move nothing.

The arm is checked through the dashboard and the RTDE receive interface only (no control script is
uploaded); the gripper's status registers are read without activating it (activation moves the
fingers); each camera must deliver frames.
"""

from __future__ import annotations

import time

import numpy as np

from drivers.cell_builders import builder_kind
from drivers.cell_file import read_cell_file, resolve_cell_path
from drivers.clock import WallClock
from drivers.hardware.camera import OpenCvCamera
from drivers.hardware.gripper_modbus import FAULTS, RobotiqConfig, RobotiqGripper
from drivers.hardware.real_cell import parse
from drivers.hardware.ur import RECEIVE_FIELDS, UrConfig
from drivers.hardware.ur_dashboard import DashboardError, preflight
from drivers.protocols import DriverFault

Result = tuple[str, bool, str]


def check_cell(cell: str) -> list[Result]:
    """One (device, ok, detail) per device of the cell file; a bad cell file raises CellFileError
    (checked whole before any device is contacted)."""
    path = resolve_cell_path(cell)
    data = read_cell_file(path)
    if data["kind"] == "sim":
        return [("cell", True, f"{path}: simulated cell, no devices to connect")]
    spec = parse(path, data, shadow=builder_kind(path, data) == "emulated_shadow")
    clock = WallClock(0.01)
    results = [check_arm(spec["arm"]), check_gripper(spec["gripper"])]
    results += [check_camera(name, cfg, clock) for name, cfg in spec["cameras"].items()]
    if spec["perception"]["source"] == "shadow":
        results.append(check_shadow(spec))
    return results


def check_shadow(spec: dict) -> Result:
    """A shadow world talks to the emulators' back doors: do both answer (read-only query)?"""
    from drivers.emulators import backdoor

    emulation = spec["emulation"]
    name = "perception (shadow world)"
    for device, host, port in (("UR", spec["arm"].host, emulation.arm_backdoor_port),
                               ("Robotiq", spec["gripper"].host, emulation.gripper_backdoor_port)):
        try:
            backdoor.call(host, port, "state", timeout=1.0)
        except (OSError, ValueError) as exc:
            return name, False, f"the {device} emulator's back door at {host}:{port} does not answer: {exc}"
    return name, True, f"both emulator back doors answer; time scale {emulation.time_scale:g}"


def check_arm(config: UrConfig) -> Result:
    """Dashboard state and a live RTDE data stream, without uploading the control script."""
    name = f"arm (UR at {config.host})"
    try:
        info = preflight(config.host, config.dashboard_timeout)
    except DashboardError as exc:
        return name, False, str(exc)
    import rtde_receive

    try:
        receive = rtde_receive.RTDEReceiveInterface(config.host, -1.0, RECEIVE_FIELDS)
    except RuntimeError as exc:
        return name, False, f"dashboard answers but RTDE (port 30004) does not: {exc}"
    try:
        t0 = receive.getTimestamp()
        time.sleep(0.1)
        fresh = receive.getTimestamp() > t0
        pose = np.round(receive.getActualTCPPose()[:3], 4).tolist()
    finally:
        receive.disconnect()
    if not fresh:
        return name, False, "RTDE connected but the controller timestamp does not advance"
    version = info["version"].replace("URSoftware ", "").split(" ")[0]
    return name, True, (f"PolyScope {version}, {info['robotmode']}, {info['safety']}, remote control; "
                        f"RTDE data live, TCP at {pose} m")


def check_gripper(config: RobotiqConfig) -> Result:
    """Read the status registers; report activation, opening and faults."""
    name = f"gripper (Robotiq at {config.host}:{config.port}, {config.framing})"
    try:
        gripper = RobotiqGripper(config)
    except DriverFault as exc:
        return name, False, str(exc)
    try:
        s = gripper.status()
        width = gripper.width()
    except DriverFault as exc:
        return name, False, str(exc)
    finally:
        gripper.close()
    if s.fault and s.fault not in (0x08, 0x09):
        return name, False, f"fault {s.fault:#04x}: {FAULTS.get(s.fault, 'unknown')}"
    state = "activated" if s.state == 3 else "not activated (the cell activates it at start)"
    return name, True, f"{state}, opening {width * 1000:.1f} mm, no fault"


def check_camera(name: str, config, clock: WallClock) -> Result:
    """Open the camera and count frames for half a second."""
    label = f"camera {name} ({config.source})"
    try:
        cam = OpenCvCamera(name, config, clock)
    except FileNotFoundError as exc:
        return label, False, str(exc)
    try:
        if not cam.wait_for_frame(config.open_timeout + 1.0):
            return label, False, cam.last_error or "no frames"
        first = cam.frames
        time.sleep(0.5)
        got = cam.read()
        fps = (cam.frames - first) / 0.5
    finally:
        cam.close()
    h, w = got[0].shape[:2] if got else (0, 0)
    return label, True, f"{w}x{h} frames at about {fps:.0f} fps"
