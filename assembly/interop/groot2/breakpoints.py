"""Groot2's hooks on a py_trees tree: breakpoints that pause the tick, and results put in a node's place.

A hook sits before (PRE) or after (POST) a node's tick. A BREAKPOINT hook, when the node is ticked,
tells Groot2 (`notify`, on the PUB socket) and waits, inside the tick, until Groot2 unlocks it; a
REPLACE hook does not wait. Either then gives the node's result when its `desired_status` is SUCCESS
or FAILURE (a PRE hook's node is then not ticked at all; a running node is stopped with that status),
and lets the node be otherwise. This is BT.CPP's `Groot2Publisher` behaviour.

While it waits, the tick thread calls `hold` (with the node's uid) every `HOLD_PERIOD` s: the run loop's own check that
the cell may stay paused (the e-stop inputs, the cell supervisor), which raises to end the run. Hooks
are allowed only where the runner can honour them safely (a simulated cell, whose world does not
move while the tick waits); elsewhere `insert` refuses with the reason. A hook is installed by
shadowing the node's `tick_once` and `tick` with wrappers on the instance, removed again with the
hook: a node without hooks ticks as before, at no cost.

The heartbeat: a client silent for `MAX_SILENCE` s disables every hook (a waiting tick goes on), as
BT.CPP does when Groot2 goes away; its next request enables them again.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator

import py_trees
from py_trees.common import Status

from assembly.interop.groot2.protocol import Hook, Mode, Position, ProtocolError

HOLD_PERIOD = 0.05  # s between the checks of a paused run
MAX_SILENCE = 5.0  # s without a request before every hook is disabled (BT.CPP's heartbeat)
RESULTS = {"SUCCESS": Status.SUCCESS, "FAILURE": Status.FAILURE}


class Breakpoints:
    """The hooks of one tree, by (uid, position); thread-safe between the server and the tick."""

    def __init__(self, nodes: dict[int, py_trees.behaviour.Behaviour], refused: str | None = None):
        self.nodes = nodes
        self.refused = refused  # why hooks are not allowed here (None: they are)
        self.notify: Callable[[int], None] = lambda uid: None  # tell Groot2 a breakpoint is reached
        self.on_pause: Callable[[], None] = lambda: None  # publish the statuses before waiting
        self.hold: Callable[[int], None] = lambda uid: None  # the run loop's checks while paused at a node
        self.paused_s = 0.0  # wall time the tree has spent waiting at breakpoints
        self.waiting: tuple[int, Position] | None = None
        self._hooks: dict[tuple[int, Position], Hook] = {}
        self._ready: set[tuple[int, Position]] = set()
        self._wrapped: dict[int, tuple[object, object]] = {}  # uid -> the node's own (tick_once, tick)
        self._inside: set[int] = set()  # uids whose wrapped tick is running (tick calls tick_once)
        self._lock = threading.Condition()

    # ---- what the server asks ------------------------------------------------------------------
    def insert(self, hook: Hook) -> None:
        """Add a hook, or update the one at its node and position (a breakpoint made a replacement
        stops waiting); ProtocolError if hooks are refused here or the uid is no node."""
        if self.refused is not None:
            raise ProtocolError(self.refused)
        if hook.uid not in self.nodes:
            raise ProtocolError("Node ID not found")
        key = (hook.uid, hook.position)
        with self._lock:
            old = self._hooks.get(key)
            self._hooks[key] = hook
            if old is not None and old.mode == Mode.BREAKPOINT and hook.mode == Mode.REPLACE:
                self._ready.add(key)
            self._lock.notify_all()
        self._wrap(hook.uid)

    def remove(self, uid: int, position: Position) -> bool:
        """Remove a hook (a tick waiting at it goes on); False if there is none."""
        with self._lock:
            hook = self._hooks.pop((uid, position), None)
            if hook is None:
                return False
            hook.enabled = False
            self._lock.notify_all()
            if not any(u == uid for u, _ in self._hooks):
                self._unwrap(uid)
        return True

    def unlock(self, uid: int, position: Position, desired: str, remove: bool) -> bool:
        """Let a breakpoint go on, with the node's result (`desired`: SUCCESS, FAILURE, or anything
        else to let the node run); `remove` removes it once done. False if there is none."""
        with self._lock:
            hook = self._hooks.get((uid, position))
            if hook is None:
                return False
            hook.desired_status = desired if desired in RESULTS else "SKIPPED"
            hook.once = hook.once or remove
            self._ready.add((uid, position))
            self._lock.notify_all()
        return True

    def remove_all(self) -> None:
        for uid, position in list(self._hooks):
            self.remove(uid, position)

    def enable_all(self, enabled: bool) -> None:
        """Enable or disable every hook (disabling lets a waiting tick go on)."""
        with self._lock:
            for hook in self._hooks.values():
                hook.enabled = enabled
            self._lock.notify_all()

    def dump(self) -> list[dict]:
        with self._lock:
            return [h.to_json() for h in self._hooks.values()]

    # ---- the tick's side -------------------------------------------------------------------------
    def _fire(self, uid: int, position: Position) -> Status | None:
        """Run the hook at (uid, position), if any: wait when it is a breakpoint; the result it
        puts in the node's place, or None to leave the node be."""
        key = (uid, position)
        with self._lock:
            hook = self._hooks.get(key)
            if hook is None or not hook.enabled:
                return None
            waits = hook.mode == Mode.BREAKPOINT
        if waits:
            self._wait(key, hook)
        with self._lock:
            if not hook.enabled:
                return None
            if hook.once:
                hook.enabled = False
                self._hooks.pop(key, None)
                if not any(u == uid for u, _ in self._hooks):
                    self._unwrap(uid)
            return RESULTS.get(hook.desired_status)

    def _wait(self, key: tuple[int, Position], hook: Hook) -> None:
        self.on_pause()
        self.notify(key[0])
        start = time.monotonic()
        self.waiting = key
        try:
            while True:
                with self._lock:
                    if key in self._ready or not hook.enabled:
                        self._ready.discard(key)
                        return
                    self._lock.wait(HOLD_PERIOD)
                self.hold(key[0])  # may raise: the run stops while paused
        finally:
            self.waiting = None
            self.paused_s += time.monotonic() - start

    def _wrap(self, uid: int) -> None:
        """Shadow the node's `tick_once` and `tick` with hooked ones (once)."""
        with self._lock:
            if uid in self._wrapped:
                return
            node = self.nodes[uid]
            tick_once, tick = node.tick_once, node.tick
            self._wrapped[uid] = (tick_once, tick)

        def hooked_tick_once() -> None:
            if uid in self._inside:  # the hooked `tick` calls `tick_once`: one node, one tick
                tick_once()
                return
            self._inside.add(uid)
            try:
                result = self._fire(uid, Position.PRE)
                if result is None:
                    tick_once()
                    result = self._fire(uid, Position.POST)
                if result is not None:
                    _give(node, result)
            finally:
                self._inside.discard(uid)

        def hooked_tick() -> Iterator[py_trees.behaviour.Behaviour]:
            if uid in self._inside:
                yield from tick()
                return
            self._inside.add(uid)
            try:
                result = self._fire(uid, Position.PRE)
                if result is None:
                    yield from tick()
                    result = self._fire(uid, Position.POST)
                if result is not None:
                    _give(node, result)
                    yield node
            finally:
                self._inside.discard(uid)

        node.tick_once = hooked_tick_once  # type: ignore[method-assign]
        node.tick = hooked_tick  # type: ignore[method-assign]

    def _unwrap(self, uid: int) -> None:
        """Give the node its own `tick_once` and `tick` back (called holding the lock)."""
        if self._wrapped.pop(uid, None) is not None:
            node = self.nodes[uid]
            for name in ("tick_once", "tick"):
                node.__dict__.pop(name, None)


def _give(node: py_trees.behaviour.Behaviour, status: Status) -> None:
    """Make `status` the node's result: a running node is stopped with it (its `terminate` runs)."""
    if node.status == Status.RUNNING:
        node.stop(status)
    node.status = status
