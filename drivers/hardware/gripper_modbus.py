"""The Gripper protocol on a Robotiq 2F-85/140 over Modbus (pymodbus): Modbus TCP through a gateway
or RTU-over-TCP through the UR RS485 URCap (port 54321).

Register map (Robotiq manual section 4.2): three command registers written with FC16 at
`command_address` (action request rACT/rGTO/rATR, position request rPR, speed rSP / force rFR) and
three status registers read with FC04 at `status_address` (gACT/gGTO/gSTA/gOBJ, fault / gPR,
position gPO / current gCU). Widths are metres at this boundary, counts (0 open .. 255 closed) on
the wire. Every request is bounded by `timeout`; a lost link latches a fault.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

from pymodbus import FramerType
from pymodbus.client import ModbusTcpClient
from pymodbus.exceptions import ModbusException

from drivers.protocols import DriverFault

log = logging.getLogger(__name__)

ACT, GTO = 0x01, 0x08
STA_ACTIVE = 3
OBJ_MOVING, OBJ_CONTACT_OPENING, OBJ_CONTACT_CLOSING = 0, 1, 2
FAULTS = {
    0x05: "action delayed: the activation must complete first",
    0x07: "the activation bit must be set before an action",
    0x08: "maximum operating temperature exceeded: let it cool down",
    0x09: "no communication for at least 1 s",
    0x0A: "under minimum operating voltage",
    0x0B: "automatic release in progress",
    0x0C: "internal fault: contact Robotiq support",
    0x0D: "activation fault: check for interference, then reactivate",
    0x0E: "overcurrent triggered: reactivate",
    0x0F: "automatic release completed: reactivate",
}
MINOR_FAULTS = {0x08, 0x09}  # logged; the gripper keeps working
FRAMERS = {"tcp": FramerType.SOCKET, "rtu": FramerType.RTU}


@dataclass(frozen=True)
class RobotiqConfig:
    """The cell file's `gripper:` section for `driver: robotiq_modbus`."""

    host: str
    port: int = 502
    framing: str = "tcp"  # tcp (Modbus TCP) or rtu (RTU frames over TCP, UR RS485 URCap)
    device_id: int = 9
    command_address: int = 1000  # 0x03E8; some Modbus TCP gateways use 0
    status_address: int = 2000  # 0x07D0
    max_width: float = 0.085  # m, opening at position count 0 (2F-85; 0.140 for a 2F-140)
    speed_range: tuple[float, float] = (0.020, 0.150)  # m/s at rSP 0 and 255
    force_range: tuple[float, float] = (20.0, 235.0)  # N at rFR 0 and 255
    timeout: float = 0.5  # s per Modbus request
    activation_timeout: float = 5.0  # s to reach gSTA = 3
    status_max_age: float = 0.01  # s a status read is reused across the calls of one tick

    def __post_init__(self):
        if self.framing not in FRAMERS:
            raise ValueError(f"gripper.framing must be one of {sorted(FRAMERS)}, got {self.framing!r}")
        if not 0 < self.device_id < 248:
            raise ValueError(f"gripper.device_id must be 1..247, got {self.device_id}")
        if self.max_width <= 0 or self.timeout <= 0:
            raise ValueError("gripper.max_width and gripper.timeout must be positive")


@dataclass(frozen=True)
class RobotiqStatus:
    """The decoded status registers."""

    activated: bool  # gACT
    going: bool  # gGTO
    state: int  # gSTA: 0 reset, 1 activating, 3 active
    obj: int  # gOBJ: 0 moving, 1/2 stopped on an object opening/closing, 3 at the request
    fault: int  # gFLT
    position_request: int  # gPR echo
    position: int  # gPO
    current: int  # gCU, about 10 mA per count

    @classmethod
    def decode(cls, regs: list[int]) -> RobotiqStatus:
        b0 = regs[0] >> 8
        return cls(bool(b0 & 0x01), bool(b0 & 0x08), (b0 >> 4) & 0x03, (b0 >> 6) & 0x03,
                   (regs[1] >> 8) & 0x0F, regs[1] & 0xFF, regs[2] >> 8, regs[2] & 0xFF)


class RobotiqGripper:
    """A Robotiq 2F over Modbus; `activate()` once, then asynchronous `move` and polling."""

    def __init__(self, config: RobotiqConfig):
        self.config = config
        self.max_width = config.max_width
        self.max_speed = config.speed_range[1]
        self._where = f"Robotiq gripper at {config.host}:{config.port} ({config.framing}, id {config.device_id})"
        self._client = ModbusTcpClient(config.host, port=config.port, framer=FRAMERS[config.framing],
                                       timeout=config.timeout, retries=0, reconnect_delay=0)
        if not self._client.connect():
            raise DriverFault(f"cannot reach {self._where}: connection refused or timed out - is it "
                              "powered, and is the gateway / RS485 URCap running?")
        self._status: RobotiqStatus | None = None
        self._status_at = 0.0
        self._link_fault: str | None = None

    # --- requests ----------------------------------------------------------------------------------
    def _write(self, regs: list[int]) -> None:
        self._request("write", lambda: self._client.write_registers(
            self.config.command_address, regs, device_id=self.config.device_id))
        self._status = None  # the next status read must see the effect of this command

    def status(self) -> RobotiqStatus:
        """Read (or reuse, within `status_max_age`) the status registers."""
        now = time.monotonic()
        if self._status is None or now - self._status_at > self.config.status_max_age:
            rr = self._request("status read", lambda: self._client.read_input_registers(
                self.config.status_address, count=3, device_id=self.config.device_id))
            self._status, self._status_at = RobotiqStatus.decode(rr.registers), now
            if self._status.fault in MINOR_FAULTS:
                log.warning("%s: %s", self._where, FAULTS[self._status.fault])
        return self._status

    def _request(self, what: str, send):
        if self._link_fault:
            raise DriverFault(self._link_fault)
        try:
            rr = send()
        except ModbusException as exc:
            self._link_fault = f"{self._where} stopped answering ({what}): {exc}"
            raise DriverFault(self._link_fault) from None
        if rr.isError():
            code = getattr(rr, "exception_code", "?")
            hint = {2: "wrong register address (check command_address/status_address)",
                    4: "device failure or wrong device_id"}.get(code, "see the Modbus exception code")
            raise DriverFault(f"{self._where} rejected the {what}: Modbus exception {code} - {hint}")
        return rr

    # --- lifecycle -------------------------------------------------------------------------------------
    def activate(self) -> None:
        """Reset then activate (manual: write 0,0,0 then 0x0100), waiting for gSTA = 3."""
        self._write([0x0000, 0x0000, 0x0000])
        self._write([ACT << 8, 0x0000, 0x0000])
        deadline = time.monotonic() + self.config.activation_timeout
        while (s := self.status()).state != STA_ACTIVE:
            if s.fault and s.fault not in MINOR_FAULTS:
                raise DriverFault(f"{self._where}: activation failed: {FAULTS.get(s.fault, s.fault)}")
            if time.monotonic() > deadline:
                raise DriverFault(f"{self._where}: not activated after {self.config.activation_timeout:g} s "
                                  f"(gSTA {s.state}) - check that nothing blocks the fingers")
            time.sleep(0.02)

    def close(self) -> None:
        self._client.close()

    # --- Gripper protocol ---------------------------------------------------------------------------
    def width(self) -> float:
        return self.max_width * (1.0 - self.status().position / 255.0)

    def move(self, width: float, speed: float = 0.05, force: float = 20.0) -> None:
        c = self.config
        self._write([(ACT | GTO) << 8, self._count(width),
                     _scale(speed, c.speed_range) << 8 | _scale(force, c.force_range)])

    def is_moving(self) -> bool:
        s = self.status()
        return s.going and s.obj == OBJ_MOVING and not self._blocking_fault(s)

    def object_detected(self) -> bool:
        return self.status().obj in (OBJ_CONTACT_OPENING, OBJ_CONTACT_CLOSING)

    def stop(self) -> None:
        """Hold the current position (rGTO cleared)."""
        s = self.status()
        self._write([ACT << 8, s.position, 0x0000])

    def fault(self) -> str | None:
        if self._link_fault:
            return self._link_fault
        try:
            s = self.status()
        except DriverFault as exc:
            return str(exc)
        if self._blocking_fault(s):
            return f"{self._where}: fault {s.fault:#04x}: {FAULTS.get(s.fault, 'unknown fault code')}"
        if s.state != STA_ACTIVE:
            return f"{self._where}: not activated (gSTA {s.state})"
        return None

    def _count(self, width: float) -> int:
        return round(min(max(1.0 - float(width) / self.max_width, 0.0), 1.0) * 255)

    @staticmethod
    def _blocking_fault(s: RobotiqStatus) -> bool:
        return s.fault != 0 and s.fault not in MINOR_FAULTS


def _scale(value: float, span: tuple[float, float]) -> int:
    """Map a physical value onto a 0..255 register byte, clamped to the device's range."""
    lo, hi = span
    return round(min(max((float(value) - lo) / (hi - lo), 0.0), 1.0) * 255)
