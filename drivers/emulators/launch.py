"""Start an emulator as a child process, wait until it listens, and always terminate it - for
tests, the drivers benchmark and `python -m drivers.emulators`.

An emulator stands in for a device with a processor of its own (a UR controller, a gripper, a
camera): where the system allows it, it runs at a higher CPU priority, so that a busy machine slows
the cell's software, as it would on a real cell, and not the emulated device's own clock."""

from __future__ import annotations

import os
import select
import subprocess
import sys
import tempfile
import time

DEVICE_NICENESS = -10  # the emulated device's priority where allowed (root, or CAP_SYS_NICE)


class EmulatorProcess:
    """`python -m <module> <args>` in its own process; a context manager."""

    def __init__(self, module: str, args: list[str], ready_timeout: float = 15.0):
        self.module, self.args, self.ready_timeout = module, args, ready_timeout
        self.proc: subprocess.Popen | None = None
        self._log = tempfile.TemporaryFile()  # noqa: SIM115 - the emulator's output, kept until stop()

    def start(self) -> EmulatorProcess:
        """Spawn the emulator and block until it prints `ready` (bounded by `ready_timeout`)."""
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen([sys.executable, "-m", self.module, *self.args],
                                     stdout=subprocess.PIPE, stderr=self._log, env=env)
        try:
            os.setpriority(os.PRIO_PROCESS, self.proc.pid, DEVICE_NICENESS)
        except (PermissionError, OSError):
            pass  # an unprivileged user keeps the normal priority: the emulator may then lag under load
        deadline = time.monotonic() + self.ready_timeout
        while time.monotonic() < deadline:
            ready, _, _ = select.select([self.proc.stdout], [], [], 0.1)
            if ready:
                line = self.proc.stdout.readline()
                if line.strip() == b"ready":
                    return self
                if not line:
                    break  # the emulator exited
        self.stop()
        raise RuntimeError(f"emulator {self.module} {' '.join(self.args)} did not start: {self.errors()}")

    def errors(self) -> str:
        """The emulator's stderr so far (for failure messages)."""
        self._log.seek(0)
        return self._log.read().decode(errors="replace")[-2000:] or "(no output)"

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def stop(self) -> None:
        """SIGTERM, then SIGKILL after 3 s."""
        if self.proc is None:
            return
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=3.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=3.0)
        self.proc.stdout.close()
        self.proc = None

    def __enter__(self) -> EmulatorProcess:  # noqa: PYI034 - typing.Self needs Python 3.11
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
