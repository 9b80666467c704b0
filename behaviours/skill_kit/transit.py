"""Transit paths for a held upright element: it passes over what lies low on the table and goes
around, never under, whatever its height band would hit (plates, whose sag under load nobody
knows, and elements standing under them), so it moves under a plate only where a skill slides
it in under the plate it props.

Obstacles are axis-aligned boxes in the base frame. The path is the shortest one through the
visibility graph of the corners of the footprints it must go around, each grown by the
element's half width and a margin."""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from behaviours.skill_kit.geometry import rotation

EPS = 1e-9  # m: a point this close to a footprint's edge is on it, not in it


@dataclass(frozen=True)
class Box:
    """An obstacle: footprint [lo, hi] in x and y, and its vertical extent [bottom, top] (m)."""

    name: str
    lo: tuple[float, float]
    hi: tuple[float, float]
    bottom: float
    top: float

    def grown(self, by: float) -> Box:
        return Box(self.name, (self.lo[0] - by, self.lo[1] - by), (self.hi[0] + by, self.hi[1] + by),
                   self.bottom, self.top)

    def contains(self, p) -> bool:
        """Inside the footprint by more than rounding (its boundary is clear)."""
        return self.lo[0] + EPS < p[0] < self.hi[0] - EPS and self.lo[1] + EPS < p[1] < self.hi[1] - EPS

    def crosses(self, a, b) -> bool:
        """Whether the segment a-b passes through the footprint's interior (slab test)."""
        t0, t1 = 0.0, 1.0
        for k in (0, 1):
            lo, hi, d = self.lo[k] + EPS, self.hi[k] - EPS, b[k] - a[k]
            if abs(d) < 1e-12:
                if not lo < a[k] < hi:
                    return False
                continue
            u, v = (lo - a[k]) / d, (hi - a[k]) / d
            t0, t1 = max(t0, min(u, v)), min(t1, max(u, v))
        return t1 > t0

    def corners(self, out: float = 1e-6) -> list[tuple[float, float]]:
        """The footprint's corners, a hair outside it."""
        return [(x, y) for x in (self.lo[0] - out, self.hi[0] + out) for y in (self.lo[1] - out, self.hi[1] + out)]


def plate_of(element: dict, plates: dict) -> dict:
    """The design plate an element props; KeyError naming both when it is missing."""
    try:
        return plates[element["plate"]]
    except KeyError:
        raise KeyError(f"element {element.get('id')!r} names plate {element.get('plate')!r}, "
                       f"which the design model does not have") from None


def plate_box(pid: str, plate: dict) -> Box:
    """A design plate: its footprint, from its soffit up."""
    x, y, z = (float(v) for v in plate["origin"])
    half = float(plate["width"]) / 2.0
    return Box(pid, (x, y - half), (x + float(plate["span"]), y + half), z, math.inf)


def element_box(eid: str, pose, size) -> Box:
    """An element of `size` [length, width, depth] (length along its own x) at centre `pose`."""
    p = np.asarray(pose, float)
    half = np.abs(rotation(p)) @ (np.asarray(size, float) / 2.0)
    lo, hi = p[:3] - half, p[:3] + half
    return Box(eid, (lo[0], lo[1]), (hi[0], hi[1]), lo[2], hi[2])


def other_elements(design, current: str) -> list[Box]:
    """The other elements of a design model (`elements()` by id): lying at their pick poses until
    placed, then standing at their as-built poses; none without a design."""
    if design is None:
        return []
    out = []
    for eid, entry in design.elements().items():
        if eid == current:
            continue
        placed = entry.get("status") in ("placing", "placed") and entry.get("asbuilt_pose") is not None
        pose = entry["asbuilt_pose"] if placed else entry.get("pick_pose")
        if pose is not None:
            out.append(element_box(eid, pose, entry["size"]))
    return out


class NoPath(ValueError):
    """No clear transit path; the message says what is in the way."""


def in_the_way(point, foot: float, head: float, obstacles: list[Box], grow: float) -> Box | None:
    """The first obstacle whose grown footprint holds `point` and whose height meets [foot, head]."""
    for box in obstacles:
        if box.bottom < head and box.top > foot and box.grown(grow).contains(point):
            return box
    return None


def transit_path(start, goal, goal_foot: float, length: float, half_width: float, obstacles: list[Box],
                 margin: float, max_foot: float) -> list[np.ndarray]:
    """TCP waypoints [x, y, z] carrying an upright element held at its middle from `start` (a TCP
    position) to above `goal` (x, y) and down to its foot at `goal_foot`: up to a transit height
    whose foot clears by `margin` what lies lower than `max_foot`, around the footprints (grown by
    `half_width` + `margin`) of all else its height band meets, then down. NoPath if there is none."""
    start = np.asarray(start, float)
    start_foot = start[2] - length / 2.0
    low = [b.top + margin for b in obstacles if b.top + margin <= max_foot]
    foot = max([start_foot, goal_foot, *low])
    grow = half_width + margin
    for point, lo, what in ((start[:2], start_foot, "start"), (goal, goal_foot, "approach point")):
        blocker = in_the_way(point, lo - margin, foot + length + margin, obstacles, grow)
        if blocker is not None:
            raise NoPath(f"{blocker.name} is in the way at the {what} ({point[0]:.3f}, {point[1]:.3f})")
    walls = [b.grown(grow) for b in obstacles if b.bottom < foot + length + margin and b.top > foot - margin]
    route = shortest_route(tuple(start[:2]), tuple(goal), walls)
    if route is None:
        names = ", ".join(sorted({b.name for b in walls}))
        raise NoPath(f"no way around {names} from ({start[0]:.3f}, {start[1]:.3f}) to ({goal[0]:.3f}, {goal[1]:.3f})")
    z = foot + length / 2.0
    out = [np.array([start[0], start[1], z])] if abs(z - start[2]) > 1e-6 else []
    out += [np.array([x, y, z]) for x, y in route[1:]]
    out.append(np.array([goal[0], goal[1], goal_foot + length / 2.0]))
    return out


def shortest_route(start: tuple, goal: tuple, walls: list[Box]) -> list[tuple] | None:
    """Shortest polyline start..goal around the walls' footprints (visibility graph, Dijkstra)."""
    nodes = [start, goal] + [c for w in walls for c in w.corners() if not any(o.contains(c) for o in walls)]

    def clear(a, b) -> bool:
        return not any(w.crosses(a, b) for w in walls)

    came: dict[int, int] = {}  # node -> the node before it on the best route found
    best, queue = {0: 0.0}, [(0.0, 0)]
    while queue:
        cost, i = heapq.heappop(queue)
        if i == 1:
            route = [goal]
            while i in came:
                i = came[i]
                route.append(nodes[i])
            return route[::-1]
        if cost > best.get(i, math.inf):
            continue
        for j, node in enumerate(nodes):
            if j == i:
                continue
            step = cost + math.dist(nodes[i], node)
            if step < best.get(j, math.inf) and clear(nodes[i], node):
                best[j], came[j] = step, i
                heapq.heappush(queue, (step, j))
    return None
