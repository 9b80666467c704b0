"""The Robotiq Modbus driver against its emulator, over Modbus TCP and RTU-over-TCP framing."""

from __future__ import annotations

import pytest
from drivers_testkit import DEADLINE, WALL_SLACK, next_host, wait_until
from pymodbus.client import ModbusTcpClient

from drivers.hardware.gripper_modbus import RobotiqConfig, RobotiqGripper
from drivers.protocols import DriverFault
from drivers.safe_gripper import SafeGripper

# Robotiq 2F-85/140 manual, Modbus RTU examples (slave 9, CRC low byte first):
MANUAL_RESET = "091003e8000306000000000000" + "7330"  # clear rACT: 1000..1002 = 0, 0, 0
MANUAL_ACTIVATE = "091003e8000306010000000000" + "72e1"  # rACT: 0x0100, 0x0000, 0x0000
MANUAL_CLOSE = "091003e8000306090000ffffff" + "4229"  # rACT|rGTO, rPR=0xFF, rSP=rFR=0xFF
MANUAL_READ_STATUS = "090407d00003" + "b1ce"  # FC04, 3 registers from 2000


def connect(emulator, framer: str) -> RobotiqGripper:
    """The driver, with a Modbus timeout a busy machine never reaches (the emulator answers at once)."""
    return RobotiqGripper(RobotiqConfig(emulator.host, port=5020, framing=framer, timeout=WALL_SLACK))


@pytest.mark.parametrize("framer", ["tcp", "rtu"])
def test_activation_then_close_on_an_object_and_open_again(start_robotiq, framer):
    emulator = start_robotiq(framer, "--object-width", "0.040")
    g = connect(emulator, framer)
    try:
        assert "not activated" in g.fault()
        g.activate()
        assert g.fault() is None and g.status().state == 3
        assert emulator.state()["registers"][0] == 0x3100  # the manual's "activation complete"
        g.move(0.0, speed=0.15, force=60.0)
        assert g.is_moving()
        assert wait_until(lambda: not g.is_moving(), DEADLINE)
        assert g.object_detected()
        assert g.width() == pytest.approx(0.040, abs=0.085 / 255)
        assert g.status().obj == 2  # stopped by contact while closing
        g.move(0.085, speed=0.15)
        assert wait_until(lambda: not g.is_moving(), DEADLINE)
        assert not g.object_detected() and g.width() == pytest.approx(0.085)
    finally:
        g.close()


def test_soft_pads_give_until_they_press_with_the_requested_force(start_robotiq):
    emulator = start_robotiq("tcp", "--object-width", "0.040", "--pad-stiffness", "5000")
    g = connect(emulator, "tcp")
    try:
        g.activate()
        g.move(0.0, speed=0.15, force=60.0)
        assert wait_until(lambda: not g.is_moving(), DEADLINE) and g.object_detected()
        assert g.width() == pytest.approx(0.040 - 60.0 / 5000, abs=0.085 / 255)
        g.move(0.035, speed=0.15, force=60.0)  # less squeeze than the force allows: reached
        assert wait_until(lambda: not g.is_moving(), DEADLINE)
        assert not g.object_detected() and g.width() == pytest.approx(0.035, abs=0.085 / 255)
    finally:
        g.close()


def test_request_bytes_match_the_manual_examples_rtu(start_robotiq):
    emulator = start_robotiq("rtu")
    g = connect(emulator, "rtu")
    try:
        g.activate()
        g.move(0.0, speed=1.0, force=1000.0)  # clamped to full speed and force: 0xFF, 0xFF
    finally:
        g.close()
    requests = emulator.call("requests")["requests"]
    writes = [r for r in requests if r[2:4] == "10"]  # FC16 frames
    assert writes == [MANUAL_RESET, MANUAL_ACTIVATE, MANUAL_CLOSE]
    assert MANUAL_READ_STATUS in requests


def test_request_bytes_match_the_manual_examples_tcp(start_robotiq):
    emulator = start_robotiq("tcp")
    g = connect(emulator, "tcp")
    try:
        g.activate()
        g.move(0.0, speed=1.0, force=1000.0)
    finally:
        g.close()
    requests = emulator.call("requests")["requests"]
    # Modbus TCP: MBAP header (transaction id, protocol 0, length, unit id) + the same PDU, no CRC
    assert all(r[4:8] == "0000" and r[12:14] == "09" for r in requests)  # protocol 0, unit 9
    pdus = [r[12:] for r in requests if r[14:16] == "10"]
    assert pdus == [MANUAL_RESET[:-4], MANUAL_ACTIVATE[:-4], MANUAL_CLOSE[:-4]]


@pytest.mark.parametrize("framer", ["tcp", "rtu"])
def test_injected_major_fault_is_reported_and_cleared_by_reactivation(start_robotiq, framer):
    emulator = start_robotiq(framer)
    g = connect(emulator, framer)
    try:
        g.activate()
        g.move(0.0)
        emulator.call("fault 0x0E")
        assert wait_until(lambda: g.fault() is not None, DEADLINE)
        assert "0x0e" in g.fault() and "overcurrent" in g.fault()
        assert not g.is_moving()
        g.activate()  # the rising edge on rACT clears a major fault
        assert g.fault() is None
    finally:
        g.close()


def test_command_before_activation_is_the_priority_fault(start_robotiq):
    emulator = start_robotiq("tcp")
    raw = ModbusTcpClient(emulator.host, port=5020, timeout=WALL_SLACK, retries=0)
    assert raw.connect()
    assert not raw.write_registers(1000, [0x0800, 0x00FF, 0xFFFF], device_id=9).isError()  # rGTO, no rACT
    raw.close()
    g = connect(emulator, "tcp")
    try:
        assert "0x07" in g.fault() and "activation bit" in g.fault()
    finally:
        g.close()


def test_wrong_device_id_and_lost_link_are_clear_faults(start_robotiq):
    emulator = start_robotiq("tcp")
    g = RobotiqGripper(RobotiqConfig(emulator.host, port=5020, device_id=8, timeout=WALL_SLACK))
    with pytest.raises(DriverFault, match="device_id"):
        g.activate()
    g.close()
    g = connect(emulator, "tcp")
    g.activate()
    emulator.process.stop()
    assert "stopped answering" in g.fault()
    with pytest.raises(DriverFault, match="stopped answering"):
        g.move(0.0)
    g.close()


def test_unreachable_gripper_gives_an_actionable_error():
    host = next_host()  # nothing listens there
    with pytest.raises(DriverFault, match=rf"cannot reach Robotiq gripper at {host}:5020"):
        RobotiqGripper(RobotiqConfig(host, port=5020, timeout=0.3))


def test_the_safety_layer_latches_the_robotiq_s_own_fault_and_keeps_bad_commands_off_the_wire(start_robotiq):
    emulator = start_robotiq("tcp")
    g = connect(emulator, "tcp")
    safe = SafeGripper(g, max_force=g.config.force_range[1])
    try:
        g.activate()

        def writes() -> list[str]:  # the FC16 (write registers) frames the gripper received, Modbus TCP
            return [r for r in emulator.call("requests")["requests"] if r[14:16] == "10"]

        before = len(writes())
        for width, speed, force in ((float("nan"), 0.05, 20.0), (0.04, 0.0, 20.0), (0.04, 0.05, 500.0)):
            safe.reset()
            safe.move(width, speed, force)
            assert "gripper move refused" in safe.fault()
        stops = writes()[before:]  # the first register's high byte: rACT alone, rGTO clear (hold)
        assert len(stops) == 3 and all(frame[26:28] == "01" for frame in stops)  # no move reached it
        safe.reset()
        safe.move(0.0, 0.15, 60.0)
        emulator.call("fault 0x0E")
        assert wait_until(lambda: safe.fault() is not None, DEADLINE)
        assert "overcurrent" in safe.fault()
        safe.move(0.085)  # latched: refused although the driver would take it
        assert "overcurrent" in safe.fault()
        emulator.process.stop()  # the link goes: stop() stays safe and the cause is added
        safe.stop()
        assert "overcurrent" in safe.fault() and "stopped answering" in safe.fault()
    finally:
        g.close()
