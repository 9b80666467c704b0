"""Whether a host is this machine's loopback: the emulators serve only loopback addresses, and only
their cells may run faster than real time."""

from __future__ import annotations

import ipaddress
import socket


def is_loopback(host: str) -> bool:
    """True for a loopback address (127.0.0.0/8, ::1), and for a name only when every address it
    resolves to is one (`localhost`); a name that does not resolve is not loopback."""
    try:
        return ipaddress.ip_address(str(host)).is_loopback
    except ValueError:
        pass
    try:
        infos = socket.getaddrinfo(str(host), None)
    except (OSError, UnicodeError):
        return False
    return bool(infos) and all(ipaddress.ip_address(info[4][0]).is_loopback for info in infos)
