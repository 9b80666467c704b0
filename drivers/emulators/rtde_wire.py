"""RTDE wire format (port 30004): message framing and the name -> type table of data fields.

ur_rtde decodes data packages with its own name -> type table, so the emulator must send every
field in the type UR documents for that name; unknown names are answered NOT_FOUND.
"""

from __future__ import annotations

import re
import socket
import struct

REQUEST_PROTOCOL_VERSION = ord("V")
GET_URCONTROL_VERSION = ord("v")
TEXT_MESSAGE = ord("M")
DATA_PACKAGE = ord("U")
SETUP_OUTPUTS = ord("O")
SETUP_INPUTS = ord("I")
START = ord("S")
PAUSE = ord("P")

# struct format and element count per RTDE type name
TYPE_FORMATS = {
    "DOUBLE": "d", "UINT64": "Q", "UINT32": "I", "INT32": "i", "UINT8": "B", "BOOL": "?",
    "VECTOR6D": "6d", "VECTOR3D": "3d", "VECTOR6INT32": "6i", "VECTOR6UINT32": "6I",
}

_FIELD_TYPES = {
    "timestamp": "DOUBLE", "actual_execution_time": "DOUBLE", "speed_scaling": "DOUBLE",
    "target_speed_fraction": "DOUBLE", "actual_momentum": "DOUBLE", "actual_main_voltage": "DOUBLE",
    "actual_robot_voltage": "DOUBLE", "actual_robot_current": "DOUBLE", "io_current": "DOUBLE",
    "standard_analog_input0": "DOUBLE", "standard_analog_input1": "DOUBLE",
    "standard_analog_output0": "DOUBLE", "standard_analog_output1": "DOUBLE",
    "tool_analog_input0": "DOUBLE", "tool_analog_input1": "DOUBLE", "tool_output_current": "DOUBLE",
    "tool_temperature": "DOUBLE", "tcp_force_scalar": "DOUBLE", "payload": "DOUBLE",
    "speed_slider_fraction": "DOUBLE",
    "target_q": "VECTOR6D", "target_qd": "VECTOR6D", "target_qdd": "VECTOR6D",
    "target_current": "VECTOR6D", "target_moment": "VECTOR6D", "actual_q": "VECTOR6D",
    "actual_qd": "VECTOR6D", "actual_current": "VECTOR6D", "joint_control_output": "VECTOR6D",
    "actual_TCP_pose": "VECTOR6D", "actual_TCP_speed": "VECTOR6D", "actual_TCP_force": "VECTOR6D",
    "target_TCP_pose": "VECTOR6D", "target_TCP_speed": "VECTOR6D", "joint_temperatures": "VECTOR6D",
    "actual_joint_voltage": "VECTOR6D", "ft_raw_wrench": "VECTOR6D", "payload_inertia": "VECTOR6D",
    "actual_current_as_torque": "VECTOR6D", "external_force_torque": "VECTOR6D",
    "actual_tool_accelerometer": "VECTOR3D", "payload_cog": "VECTOR3D", "elbow_position": "VECTOR3D",
    "elbow_velocity": "VECTOR3D",
    "robot_mode": "INT32", "safety_mode": "INT32", "safety_status": "INT32",
    "tool_output_voltage": "INT32", "joint_mode": "VECTOR6INT32",
    "actual_digital_input_bits": "UINT64", "actual_digital_output_bits": "UINT64",
    "runtime_state": "UINT32", "robot_status_bits": "UINT32", "safety_status_bits": "UINT32",
    "analog_io_types": "UINT32", "tool_mode": "UINT32", "tool_analog_input_types": "UINT32",
    "script_control_line": "UINT32", "speed_slider_mask": "UINT32",
    "output_bit_registers0_to_31": "UINT32", "output_bit_registers32_to_63": "UINT32",
    "standard_digital_output_mask": "UINT8", "standard_digital_output": "UINT8",
    "configurable_digital_output_mask": "UINT8", "configurable_digital_output": "UINT8",
    "tool_digital_output_mask": "UINT8", "tool_digital_output": "UINT8",
}
_REGISTER = re.compile(r"^(input|output)_(int|double|bit)_register_(\d+)$")
_REGISTER_TYPES = {"int": "INT32", "double": "DOUBLE", "bit": "BOOL"}


def field_type(name: str) -> str | None:
    """The RTDE type of a data field, or None when the controller does not know the name."""
    m = _REGISTER.match(name)
    if m:
        return _REGISTER_TYPES[m.group(2)] if int(m.group(3)) < 48 else None
    return _FIELD_TYPES.get(name)


def pack(msg_type: int, payload: bytes = b"") -> bytes:
    """One framed message: u16 size (header included), u8 type, payload."""
    return struct.pack(">HB", len(payload) + 3, msg_type) + payload


def read_message(sock: socket.socket) -> tuple[int, bytes]:
    """Read exactly one framed message; raises ConnectionError when the peer closes."""
    size, msg_type = struct.unpack(">HB", _read_exactly(sock, 3))
    if size < 3:
        raise ConnectionError(f"malformed RTDE header: size {size}")
    return msg_type, _read_exactly(sock, size - 3)


def _read_exactly(sock: socket.socket, n: int) -> bytes:
    buf = bytearray()
    while len(buf) < n:
        chunk = sock.recv(n - len(buf))
        if not chunk:
            raise ConnectionError("peer closed the RTDE connection")
        buf += chunk
    return bytes(buf)


class Recipe:
    """A negotiated list of fields with their types; packs and unpacks data packages."""

    def __init__(self, recipe_id: int, names: list[str]):
        self.id = recipe_id
        self.names = names
        self.types = [field_type(n) for n in names]
        self.valid = all(self.types)
        fmt = "".join(TYPE_FORMATS[t] for t in self.types) if self.valid else ""
        self._struct = struct.Struct(">" + fmt)

    def types_text(self) -> str:
        return ",".join(t or "NOT_FOUND" for t in self.types)

    def pack(self, values: dict[str, object]) -> bytes:
        flat: list = []
        for name, typ in zip(self.names, self.types):
            v = values.get(name, 0)
            if typ.startswith("VECTOR"):
                flat.extend(v if v else [0] * int(TYPE_FORMATS[typ][0]))
            else:
                flat.append(v)
        return bytes([self.id]) + self._struct.pack(*flat)

    def unpack(self, body: bytes) -> dict[str, object]:
        flat = list(self._struct.unpack(body))
        out: dict[str, object] = {}
        for name, typ in zip(self.names, self.types):
            n = int(TYPE_FORMATS[typ][0]) if typ.startswith("VECTOR") else 1
            out[name] = flat[:n] if n > 1 else flat[0]
            del flat[:n]
        return out
