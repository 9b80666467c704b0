"""Loopback emulators that speak the real wire protocols (UR RTDE/dashboard/script ports, Robotiq
Modbus, MJPEG over HTTP), so driver tests and `fvtree check` run without hardware.

Each emulator is a separate process (`python -m drivers.emulators.<name> --help`); the UR one must
be, because ur_rtde constructors hold the GIL. Bind them to distinct 127.0.0.x addresses.
"""
