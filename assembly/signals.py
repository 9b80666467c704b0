"""SIGTERM handled like Ctrl-C: within `sigterm_raises_terminated`, SIGTERM raises `Terminated`
(a KeyboardInterrupt), so a run's tick loop halts the tree and a viewer stops serving the same way
for either."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the tick loop like Ctrl-C so that it halts the run the same way."""


def _raise_terminated(signum, frame) -> None:
    raise Terminated()


@contextmanager
def sigterm_raises_terminated() -> Iterator[None]:
    """Within the block, SIGTERM raises `Terminated` (a KeyboardInterrupt), so it stops a tick loop
    or a wait like Ctrl-C; the previous handler is restored after. Signals reach the main thread only."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
