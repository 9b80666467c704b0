"""What every safety wrapper around a device shares: the finiteness and range checks of the numbers
that cross the safety boundary, and `Guard`, which latches faults, refuses commands while faulted,
and turns anything a driver raises (in a command or a state read) into a latched fault.

`drivers.safety.SafeArm` and `drivers.safe_gripper.SafeGripper` build on it. A refused command
never reaches the driver: it latches a fault naming the command and the bad value, and the device
stops. Faults stay latched until `reset` is called by a person (never automatically).
"""

from __future__ import annotations

import logging
import math
import reprlib
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from drivers.protocols import DriverFault

log = logging.getLogger(__name__)
ROTVEC_TOLERANCE = 1e-3  # rad a rotation vector may exceed pi by (rounded angles such as 3.141593)
FLOAT = np.dtype(float)  # made once: numpy works out `dtype=float` anew on every call, which costs more than the copy


class Refused(ValueError):
    """A command argument or a reading the safety layer will not pass on."""


def finite_number(what: str, value: Any) -> float:
    """`value` as a finite float, or Refused."""
    if isinstance(value, (bool, np.bool_)):
        raise Refused(f"{what} {value!r} is not a number")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise Refused(f"{what} {reprlib.repr(value)} is not a number") from None
    if not math.isfinite(x):
        raise Refused(f"{what} {x!r} is not finite")
    return x


def positive_number(what: str, value: Any) -> float:
    """`value` as a finite float above zero, or Refused."""
    x = finite_number(what, value)
    if x <= 0.0:
        raise Refused(f"{what} {x!r} must be positive")
    return x


def finite_vector(what: str, value: Any, size: int = 6) -> np.ndarray:
    """`value` as a finite float vector of `size` entries, or Refused."""
    try:
        v = np.array(value, dtype=FLOAT)
    except (TypeError, ValueError):
        raise Refused(f"{what} {reprlib.repr(value)} is not a vector of numbers") from None
    if v.shape != (size,):
        raise Refused(f"{what} must be {size} numbers, got shape {v.shape}")
    if not all(map(math.isfinite, v.tolist())):  # on Python floats: a fraction of numpy's per-call cost
        raise Refused(f"{what} {v.tolist()} is not finite")
    return v


def finite_pose(what: str, value: Any) -> np.ndarray:
    """A finite pose [x, y, z, rx, ry, rz] whose rotation vector turns at most pi, or Refused."""
    p = finite_vector(what, value)
    angle = float(np.linalg.norm(p[3:]))
    if angle > math.pi + ROTVEC_TOLERANCE:
        raise Refused(f"{what} {p.tolist()}: rotation vector of norm {angle:.4f} rad is beyond pi")
    return p


def truth_value(what: str, value: Any) -> bool:
    """A yes/no reading as a bool (anything the driver says is one)."""
    return bool(value)


def describe(exc: BaseException) -> str:
    """A driver exception as fault text: a DriverFault's own words, anything else with its type."""
    return str(exc) if isinstance(exc, DriverFault) else f"{type(exc).__name__}: {exc}"


class Guard:
    """The latch shared by the safety wrappers: `inner` is the wrapped driver, `device` names it
    in fault texts. Subclasses call `_gate`, `_forward` and `_read` around every command and read."""

    def __init__(self, inner: Any, device: str):
        self.inner = inner
        self.device = device
        self._causes: list[str] = []  # every latched fault, first first
        self._lock = threading.RLock()  # the tick thread and watchdog threads both supervise
        self._last: dict[str, Any] = {}  # the last good value of each reading
        # Told (device, command, checked arguments) of every command passed on to the driver (and of
        # every stop), e.g. by the run recorder; they must not raise.
        self.observers: list[Callable[[str, str, tuple], None]] = []

    # --- faults ---------------------------------------------------------------------------------
    def fault(self) -> str | None:
        """Every latched cause, and the driver's own fault (which latches too), as one text."""
        driver = self._read("fault", self.inner.fault, None, _fault_text)
        if driver and not any(driver in cause for cause in self._causes):
            self.trip(f"driver fault: {driver}")
        return "; ".join(self._causes) or None

    def trip(self, reason: str) -> None:
        """Latch `reason` as a fault and stop the device."""
        with self._lock:
            self._latch(reason)
            self._halt()

    def stop(self) -> None:
        """Stop the device; always safe to call (a driver that raises latches a fault instead)."""
        with self._lock:
            self._halt()

    def reset(self) -> None:
        """Clear the latched faults; for a person who has checked the cell, never automatic."""
        with self._lock:
            self._causes.clear()

    def _latch(self, reason: str) -> None:
        with self._lock:
            if reason not in self._causes:
                self._causes.append(reason)  # first: no command may slip in while the device stops
                log.error("safety stop (%s): %s", self.device, reason)

    def _halt(self) -> None:
        for observe in self.observers:
            observe(self.device, "stop", ())
        try:
            self.inner.stop()
        except Exception as exc:  # noqa: BLE001 - whatever a driver raises is a fault, never a crash past the gate
            self._latch(f"driver fault during stop: {describe(exc)}")

    # --- commands and reads -----------------------------------------------------------------------
    def _refuse(self, what: str) -> bool:
        """True (and a warning) when a fault is latched: no command passes then."""
        if self._causes:
            log.warning("%s refused: %s is stopped (%s)", what, self.device, "; ".join(self._causes))
            return True
        return False

    def _gate(self, what: str, check: Callable[[], Any]) -> Any:
        """`check()`'s checked arguments, or None after latching a fault when it refuses them."""
        try:
            return check()
        except Refused as exc:
            self.trip(f"{what} refused: {exc}")
            return None

    def _forward(self, what: str, command: Callable[..., Any], *args) -> None:
        """Pass a checked command on; whatever the driver raises latches a fault and stops."""
        for observe in self.observers:
            observe(self.device, what, args)
        try:
            command(*args)
        except Exception as exc:  # noqa: BLE001 - as above
            self.trip(f"driver fault during {what}: {describe(exc)}")

    def _read(self, what: str, read: Callable[[], Any], fallback: Any, check: Callable[[str, Any], Any]) -> Any:
        """A checked reading; a driver that raises or a reading `check` refuses (non-finite, wrong
        shape) latches a fault and stops, and the last good reading (else `fallback`) is returned."""
        try:
            value = check(what, read())
        except Refused as exc:
            self.trip(f"bad reading: {exc}")
            return _copy(self._last.get(what, fallback))
        except Exception as exc:  # noqa: BLE001 - as above
            self.trip(f"driver fault reading {what}: {describe(exc)}")
            return _copy(self._last.get(what, fallback))
        self._last[what] = _copy(value)
        return value


def _fault_text(what: str, value: Any) -> str | None:
    return None if value is None else str(value)


def _copy(value: Any) -> Any:
    """Arrays copied, so that no caller changes a kept reading."""
    return value.copy() if isinstance(value, np.ndarray) else value
