"""Per-tick data kept until it is sent: the recorder keeps each tick's values in the batch's column
lists (no Rerun call a tick), turns them into arrays once per batch and sends each column once per
batch with `send_columns`, whose fixed cost (0.05-0.1 ms a call) is then shared by a whole batch of ticks."""

from __future__ import annotations

import threading
from operator import attrgetter
from typing import Any

import numpy as np
import rerun as rr

FINGER_VALUES = ("force", "torque", "slip", "area", "centroid", "orientation", "healthy", "present", "position",
                 "valid")  # the columns a finger's TactileState gives a tick


def column(descriptor: str | rr.ComponentDescriptor, batch: rr.ComponentBatchLike,
           per_row: int) -> rr.ComponentColumn:
    """`batch` split into rows of `per_row` values each: the column an archetype's `columns(...)` and
    `partition(...)` make, built straight from it (they cost 0.05-0.4 ms a call checking the input and
    first splitting it into rows of one value each)."""
    size = len(batch.as_arrow_array())
    return rr.ComponentColumn(descriptor, batch, offsets=np.arange(0, size + 1, per_row, dtype=np.int32))


def scalars_column(values: np.ndarray) -> rr.ComponentColumn:
    """(n, k) values as the `Scalars` column of n rows of k values each."""
    return column(rr.Scalars.descriptor_scalars(), rr.components.ScalarBatch(values), values.shape[1])


def time_columns(ticks: np.ndarray, times: np.ndarray) -> list[rr.TimeColumn]:
    """The two timelines of every row: the tick number and the cell time (seconds)."""
    return [rr.TimeColumn("tick", sequence=ticks), rr.TimeColumn("cell_time", duration=times)]


class Sparse:
    """Rows that come now and then (a status change, a command, an event): (tick, time) and the
    values of each row, sent with the next batch. Rows may come from another thread (the safety
    layer's watchdog stops the arm from its own): adding and taking hold a lock, so that a batch
    never has more values than times (Rerun then refuses the whole batch)."""

    def __init__(self):
        self.ticks: list[int] = []
        self.times: list[float] = []
        self.values: list[Any] = []
        self._lock = threading.Lock()

    def add(self, tick: int, time: float, value: Any) -> None:
        with self._lock:
            self.ticks.append(tick)
            self.times.append(time)
            self.values.append(value)

    def take(self) -> tuple[list[rr.TimeColumn], list[Any]] | None:
        """The time columns and values kept so far (and forget them), or None when empty."""
        with self._lock:
            if not self.ticks:
                return None
            ticks, times, values = self.ticks, self.times, self.values
            self.ticks, self.times, self.values = [], [], []
        return time_columns(np.array(ticks, np.int64), np.array(times)), values


class TickColumns:
    """The per-tick values of one batch, a list per column: references to the tick's readings (the
    perception stage publishes new ones every tick and never changes one it handed out), no object
    made a tick, so the heap's collector has nothing new to walk; turned into arrays once per batch,
    each column list emptied as it is read, so that its readings are freed while still in the cache
    (a batch's kept readings freed all at once, later, cost the tick ~2x as much). A batch holds at most
    `capacity` ticks, all of one marker calibration per finger (`origins`)."""

    def __init__(self, capacity: int, states: tuple = ()):
        self.capacity = capacity
        self.origins = [state.markers.origin for state in states]
        self._every = [np.ones(len(origin), bool) for origin in self.origins]  # a field with no validity flags
        self.ticks: list[int] = []
        self.times: list[float] = []
        self.robot: tuple[list, ...] = ([], [], [], [])  # pose, wrench, gripper width, object flag
        self.fingers: list[tuple[list, ...]] = [tuple([] for _ in FINGER_VALUES) for _ in states]
        self._append = [tuple(column.append for column in columns) for columns in self.fingers]

    @property
    def n(self) -> int:
        return len(self.ticks)

    def takes(self, states: tuple) -> bool:
        """Whether this tick's `states` may join the batch: room left, and the same calibrations."""
        if len(self.ticks) >= self.capacity:
            return False
        for state, origin in zip(states, self.origins):  # a plain loop: all() over a generator costs more
            if state.markers.origin is not origin:
                return False
        return True

    def add(self, tick: int, now: float, pose: np.ndarray, wrench: np.ndarray, width: float, holding: bool,
            states: tuple) -> None:
        """One tick's row: `states` are the fingers' TactileStates, as the batch was made for."""
        self.ticks.append(tick)
        self.times.append(now)
        robot = self.robot
        robot[0].append(pose)
        robot[1].append(wrench)
        robot[2].append(width)
        robot[3].append(holding)
        for append, state, every in zip(self._append, states, self._every):
            obj, field = state.obj, state.markers
            force, torque, slip, area, centroid, orientation, healthy, present, position, valid = append
            force(state.force)
            torque(state.torque)
            slip(state.slip)
            area(obj.area)
            centroid(obj.centroid)
            orientation(obj.orientation)
            healthy(state.healthy)
            present(obj.present)
            position(field.position)
            valid(field.valid if len(field.valid) else every)

    def index(self) -> list[rr.TimeColumn]:
        """The time columns of the batch."""
        return time_columns(np.array(self.ticks, np.int64), np.array(self.times))

    def robot_table(self) -> np.ndarray:
        """(n, 14): pose, wrench, gripper width, object flag (once: their columns are emptied)."""
        pose, wrench, width, holding = self.robot
        table = np.empty((self.n, 14))
        table[:, 0:6] = _stack(pose, 6)
        table[:, 6:12] = _stack(wrench, 6)
        table[:, 12] = _numbers(width)
        table[:, 13] = _numbers(holding)
        return table

    def finger_table(self, k: int, valid: np.ndarray) -> np.ndarray:
        """(n, 14) of finger `k`: force, torque, slip, object area, centroid and orientation, healthy,
        the share of valid markers (of `valid`, its (n, markers) validity) and the object flag (once: their
        columns are emptied)."""
        force, torque, slip, area, centroid, orientation, healthy, present = self.fingers[k][:8]
        table = np.empty((self.n, 14))
        table[:, 0:3] = _stack(force, 3)
        table[:, 3:6] = _stack(torque, 3)
        table[:, 6] = _numbers(slip)
        table[:, 7] = _numbers(area)
        table[:, 8:10] = _stack(centroid, 2)
        table[:, 10] = _numbers(orientation)
        table[:, 11] = _numbers(healthy)
        table[:, 12] = valid.mean(axis=1) if valid.shape[1] else 0.0
        table[:, 13] = _numbers(present)
        return table

    def arrows(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(n, markers, 2) displacement arrows and (n, markers) validity of finger `k`'s markers (once:
        their columns are emptied)."""
        origin = self.origins[k]
        m = len(origin)
        positions, valid = self.fingers[k][8:10]
        arrows = _stack(positions, 2 * m).reshape(self.n, m, 2)
        return np.subtract(arrows, origin, out=arrows), _stack(valid, m, bool)


def _numbers(values: list) -> np.ndarray:
    """(n,) floats of n numbers (or flags); `values` is emptied."""
    array = np.fromiter(values, float, len(values))
    values.clear()
    return array


def _stack(values: list, width: int, dtype: type = float) -> np.ndarray:
    """(n, width) array of n arrays of `width` values each (as `dtype`); `values` is emptied."""
    stacked = _joined(values, width, np.dtype(dtype)) if values else np.empty((0, width), dtype)
    if stacked is None:
        stacked = np.concatenate(values).reshape(len(values), width).astype(dtype, copy=False)
    values.clear()
    return stacked


def _joined(values: list, width: int, dtype: np.dtype) -> np.ndarray | None:
    """The arrays' bytes joined into an (n, width) array, 3-4x faster than np.concatenate over a batch
    of small arrays; None unless they are contiguous arrays of `dtype` (not a view of every other
    column, a list or another type; every one is checked: arrays of another type of the same size would
    join into wrong numbers)."""
    try:
        if set(map(attrgetter("dtype"), values)) != {dtype}:
            return None
    except AttributeError:  # not arrays
        return None
    try:
        joined = bytearray().join(values)
    except TypeError:  # an array that is not one block of memory
        return None
    if len(joined) != len(values) * width * dtype.itemsize:
        return None
    return np.frombuffer(joined, dtype).reshape(len(values), width)
