"""Robotiq 2F gripper emulator on a pymodbus server: Modbus TCP or RTU-over-TCP framing (as the UR
RS485 URCap exposes it on port 54321), command registers written with FC16 and status registers
read with FC04, motion over time, an object at a configurable width, and injectable faults.

    python -m drivers.emulators.robotiq --host 127.0.0.3 --port 5020 [--framer tcp|rtu]
        [--device-id 9] [--command-address 1000] [--status-address 2000] [--stroke 0.085]
        [--object-width 0.04] [--activation-time 0.3] [--backdoor-port 30998]

Back door (see backdoor.py): `state`, `fault CODE` (e.g. `fault 0x0E` overcurrent), `object
WIDTH|none`, `requests` (the raw request frames received, hex, newest last). Prints `ready` once
it listens; exits on SIGTERM or SIGINT.
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import logging
import signal
import sys

from pymodbus import FramerType
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from drivers.emulators import backdoor
from drivers.emulators.robotiq_model import GripperSpec, RobotiqModel
from drivers.loopback import is_loopback

FRAMERS = {"tcp": FramerType.SOCKET, "rtu": FramerType.RTU}


class RobotiqEmulator:
    """A `RobotiqModel` behind one Modbus device, with a log of the raw request frames."""

    def __init__(self, model: RobotiqModel, device_id: int, command_address: int, status_address: int):
        self.model = model
        self.command_address = command_address
        self.status_address = status_address
        self.commands = [0, 0, 0]
        self.requests: collections.deque[str] = collections.deque(maxlen=200)
        blocks = ([SimData(0, values=0, datatype=DataType.BITS)],
                  [SimData(0, values=0, datatype=DataType.BITS)],
                  [SimData(command_address, count=3, values=0, datatype=DataType.REGISTERS)],
                  [SimData(status_address, count=3, values=0, datatype=DataType.REGISTERS)])
        self.device = SimDevice(id=device_id, simdata=blocks, action=self._action)

    async def _action(self, fc, start_address, address, count, registers, set_values):
        """pymodbus hook before each request: feed writes to the model, refresh the status block."""
        if set_values is not None and start_address == self.command_address:
            offset = address - self.command_address
            self.commands[offset:offset + len(set_values)] = list(set_values)
            self.model.write(self.commands)
        if start_address == self.status_address:
            registers[0:3] = self.model.registers()

    def trace(self, sending: bool, data: bytes) -> bytes:
        if not sending:
            self.requests.append(data.hex())
        return data

    def handle(self, command: str, args: list[str]) -> dict:
        m = self.model
        if command == "state":
            regs = m.registers()
            return {"ok": True, "registers": regs, "width": m.spec.stroke * (1 - (regs[2] >> 8) / 255),
                    "fault": m.fault, "object_width": m.spec.object_width}
        if command == "fault":
            m.inject_fault(int(args[0], 0))
        elif command == "object":
            with m.lock:
                m.spec.object_width = None if args[0] == "none" else float(args[0])
        elif command == "requests":
            return {"ok": True, "requests": list(self.requests)}
        else:
            return {"ok": False, "error": f"unknown command {command!r}; known: state, "
                    "fault CODE, object WIDTH|none, requests"}
        return {"ok": True}


async def serve(host: str, port: int, framer: str, emulator: RobotiqEmulator) -> None:
    server = ModbusTcpServer(emulator.device, address=(host, port), framer=FRAMERS[framer],
                             trace_packet=emulator.trace)
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, lambda: asyncio.ensure_future(server.shutdown()))
    task = asyncio.ensure_future(server.serve_forever())
    await asyncio.sleep(0.2)  # let the listener bind before announcing readiness
    if task.done():
        await task  # re-raise the bind error
    print("ready", flush=True)
    await task


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m drivers.emulators.robotiq",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--host", default="127.0.0.3", help="loopback address to bind")
    p.add_argument("--port", type=int, default=5020, help="Modbus port (502 TCP, 54321 UR RS485 URCap)")
    p.add_argument("--framer", choices=sorted(FRAMERS), default="tcp",
                   help="tcp: Modbus TCP (MBAP header); rtu: RTU frames with CRC over TCP")
    p.add_argument("--device-id", type=int, default=9, help="Modbus unit id (Robotiq default 9)")
    p.add_argument("--command-address", type=int, default=1000, help="first command register")
    p.add_argument("--status-address", type=int, default=2000, help="first status register")
    p.add_argument("--stroke", type=float, default=0.085, help="opening at position 0 (m)")
    p.add_argument("--object-width", type=float, default=None, help="width of a grippable object (m)")
    p.add_argument("--speed-range", type=float, nargs=2, default=(0.020, 0.150), metavar=("LO", "HI"),
                   help="finger speed at rSP 0 and 255 (m/s; default 2F-85)")
    p.add_argument("--force-range", type=float, nargs=2, default=(20.0, 235.0), metavar=("LO", "HI"),
                   help="grip force at rFR 0 and 255 (N; default 2F-85)")
    p.add_argument("--pad-stiffness", type=float, default=None,
                   help="stiffness of the soft fingertip pads (N/m); default rigid fingers")
    p.add_argument("--activation-time", type=float, default=0.3, help="activation duration (s)")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="emulated seconds per wall-clock second (speeds up long runs in tests)")
    p.add_argument("--backdoor-port", type=int, default=30998, help="fault-injection port")
    args = p.parse_args(argv)
    if not is_loopback(args.host):
        p.error("the emulator binds loopback addresses only (127.0.0.0/8, ::1, localhost)")
    if args.time_scale <= 0:
        p.error("--time-scale must be positive")
    logging.basicConfig(level=logging.WARNING)
    spec = GripperSpec(stroke=args.stroke, activation_time=args.activation_time,
                       min_speed=args.speed_range[0], max_speed=args.speed_range[1],
                       min_force=args.force_range[0], max_force=args.force_range[1],
                       object_width=args.object_width, pad_stiffness=args.pad_stiffness,
                       time_scale=args.time_scale)
    emulator = RobotiqEmulator(RobotiqModel(spec), args.device_id, args.command_address,
                               args.status_address)
    try:
        backdoor.serve(args.host, args.backdoor_port, emulator.handle)
        asyncio.run(serve(args.host, args.port, args.framer, emulator))
    except OSError as exc:
        print(f"cannot listen on {args.host}: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
