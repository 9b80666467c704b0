"""The architectural-assembly scene: elements lying at a pick area, bendable plates to prop,
the ground, and what each FingerVision fingertip feels and sees.

Frames: base frame z up, ground at z = 0. The gripper closes along the tool y axis; each
finger's image x runs along the tool x axis (mirrored on the left finger), image y along the
tool z axis. A held element carries the plate load R(a) through the grip (the gel is part of
the series compliance k), so the fingers feel it as shear.

Elements are solid: a held element that would pass through another one is held back where it
touched, so the hand drags it over the pads against a stiff contact (the fingers feel it, and
the arm's force limit stops the motion); the fingers grasp only the element between them, never
a second one while they hold the first. Plates are not solid (an element under one loads it), but a
held element that pushes on a plate it does not prop, or lifts any plate off its supports, is a
shortfall in the truth's verdict.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.models.fingervision_model import FingerContact
from drivers.sim.models.plate import BeamPlate
from drivers.sim.scenes import randomise
from drivers.sim.scenes.base import Scene
from drivers.sim.scenes.scene_file import plate_loads, scene_file_of
from drivers.sim.transforms import compose, homogeneous, inverse_entries, pose_of, rigid_inverse, rotation_entries
from perception.state import FINGERS, ObjectInfo

GRAVITY = 9.81
CURVE_POINTS = 2001  # samples of the true load curve along a plate's span
STRAY_LOAD_N = 1.0  # load from a plate an element does not prop that counts as pushing it (N)
NORMAL_DRAWS = 256  # standard normal draws taken from the scene's generator at a time
ROUNDING_MARGIN = 1e-9  # m, far beyond the rounding of distances of a few metres
Point = tuple[float, float, float]
NO_FORCE: Point = (0.0, 0.0, 0.0)
SIDES = (-1.0, 1.0)  # tool-y sides of the left and right fingertips
_THREE_FLOATS = struct.Struct("3d")  # three numbers as bytes, to compare them bit for bit (0.0 is not -0.0)


@dataclass(eq=False, slots=True)  # not frozen: a frozen dataclass takes 3x as long to make
class Frame:
    """What an element's pose implies, on Python floats: worked out once per pose, as most elements
    lie or stand still for many ticks and a held one is asked about several times a tick."""

    key: bytes  # the pose's bytes
    centre: Point
    rotation: tuple[float, ...]  # element-to-base rotation, row by row
    ends: tuple[Point, Point]  # (bottom, top) end points of the element axis, by height
    core: tuple[Point, Point]  # axis of the capsule standing in for the element (radius half its width)
    core_half: float  # half the core's length: no point of the core is further from the centre
    inverse: tuple[float, ...]  # base-to-element transform, its top 3 rows, row by row

    @classmethod
    def of(cls, key: bytes, pose: np.ndarray, length: float, width: float) -> Frame:
        """The frame of an element `length` long and `width` wide whose centre is at `pose` (bytes `key`)."""
        p = pose.tolist()
        r = rotation_entries(p[3:6])
        half, core_half = length / 2.0, max(length / 2.0 - width / 2.0, 0.0)
        a, b = _along(p, r, -half), _along(p, r, half)
        return cls(key, (p[0], p[1], p[2]), r, (a, b) if a[2] <= b[2] else (b, a),
                   (_along(p, r, -core_half), _along(p, r, core_half)), core_half, inverse_entries(r, p))

    def local(self, x: float, y: float, z: float) -> Point:
        """The base-frame point (x, y, z) in the element frame; the products are summed as numpy sums
        those of a 4x4 matrix-vector product ((0 + 2) + (1 + 3)), so that results stay the same bit for bit."""
        i = self.inverse
        return ((i[0] * x + i[2] * z) + (i[1] * y + i[3]), (i[4] * x + i[6] * z) + (i[5] * y + i[7]),
                (i[8] * x + i[10] * z) + (i[9] * y + i[11]))

    def is_upright(self, tol: float = 0.1) -> bool:
        """Whether the element axis is within `tol` (of the cosine) of vertical."""
        return abs(self.rotation[6]) > 1.0 - tol


def _along(p: list[float], r: tuple[float, ...], s: float) -> Point:
    """The point `s` along the x axis of rotation `r` from the point `p`."""
    return p[0] + r[0] * s, p[1] + r[3] * s, p[2] + r[6] * s


@dataclass
class Element:
    """A box-shaped vertical element; its length runs along its own x axis."""

    id: str
    length: float
    width: float  # across the fingers
    depth: float
    mass: float
    pose: np.ndarray  # centre pose [x, y, z, rx, ry, rz]
    state: str = "lying"  # lying | held | standing | dropped
    plate: str = ""  # the plate the design has it prop ("": any)
    grasp: np.ndarray | None = None  # element pose in the tool frame while held (4x4)
    _frame: Frame | None = field(default=None, repr=False)

    def frame(self, pose: np.ndarray | None = None) -> Frame:
        """The element's frame were its centre at `pose` (default: where it is), kept for the last
        pose asked about (compared by its bytes, as a pose may be changed in place)."""
        pose = self.pose if pose is None else pose
        key = pose.tobytes()
        if self._frame is None or self._frame.key != key:
            self._frame = Frame.of(key, pose, self.length, self.width)
        return self._frame

    def ends(self) -> tuple[Point, Point]:
        """(bottom, top) end points of the element axis, by height."""
        return self.frame().ends

    def is_upright(self, tol: float = 0.1) -> bool:
        return self.frame().is_upright(tol)


def segment_distance(p0: Point, p1: Point, q0: Point, q1: Point) -> float:
    """Least distance between the segments p0-p1 and q0-q1 (clamped closest points), on Python floats."""
    d1 = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]]
    d2 = [q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]]
    r = [p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]]
    a, e, f = _dot(d1, d1), _dot(d2, d2), _dot(d2, r)
    c, b = _dot(d1, r), _dot(d1, d2)
    denom = a * e - b * b
    s = _unit((b * f - c * e) / denom) if denom > 1e-12 else 0.0
    t = (b * s + f) / e if e > 1e-12 else 0.0
    if t < 0.0 or t > 1.0:
        t = _unit(t)
        s = _unit((b * t - c) / a) if a > 1e-12 else 0.0
    return math.dist([p0[i] + d1[i] * s for i in range(3)], [q0[i] + d2[i] * t for i in range(3)])


def _capsules_meet(a: Frame, a_width: float, b: Frame, b_width: float) -> bool:
    """Whether the capsules of two elements (frames `a`, `b`) intersect; ones whose centres are further
    apart than their half cores and radii together are not measured (most elements are far apart)."""
    reach = (a_width + b_width) / 2.0
    if math.dist(a.centre, b.centre) > a.core_half + b.core_half + reach + ROUNDING_MARGIN:
        return False
    return segment_distance(*a.core, *b.core) < reach


def _dot(u: list[float], v: list[float]) -> float:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _unit(x: float) -> float:
    """`x` clamped to [0, 1]."""
    return min(max(x, 0.0), 1.0)


@dataclass
class Plate:
    """A plate strip spanning along +x from `origin` (left support) at height `origin[2]`."""

    id: str
    origin: Point  # left support (x, y, z_soffit), on Python floats: a held element asks about it every tick
    width: float  # extent across (y)
    beam: BeamPlate

    def position_along(self, p: Point) -> float | None:
        """Distance a from the left support if p lies under the plate footprint, else None."""
        a = p[0] - self.origin[0]
        if 0.0 <= a <= self.beam.span and abs(p[1] - self.origin[1]) <= self.width / 2.0:
            return a
        return None


@dataclass
class SceneConfig:
    """Physical constants of the simulated assembly cell (not known to the design model)."""

    ground_stiffness: float = 20000.0  # N/m, element foot on the ground
    friction: float = 0.8  # gel-element friction coefficient
    view_half: float = 0.015  # m, half the fingertip camera window along the tool x axis
    finger_reach: float = 0.03  # m, fingertip length along the tool z axis
    force_noise: float = 0.02  # std of load noise, share of the plate's true maximum
    contact_stiffness: float = 20000.0  # N/m, a held element pressed against another one
    seed: int = 0


@dataclass
class AssemblyScene(Scene):
    PROVIDES: ClassVar[frozenset[str] | None] = frozenset({"surface", "elements", "plates"})  # for skills' NEEDS
    arm: SceneArm
    gripper: SceneGripper
    elements: dict[str, Element]
    plates: dict[str, Plate]
    config: SceneConfig = field(default_factory=SceneConfig)

    def __post_init__(self):
        self._rng = np.random.default_rng(self.config.seed)
        self._draws: list[float] = []  # standard normal draws not used yet, the next one last
        self._loads: dict[str, float] = {}  # element id -> true load it carries now (N)
        self._slip = 0.0
        self._noise_scale: dict[str, float] = {}  # plate id -> load noise std (N)
        self._contact = NO_FORCE  # N, another element pushing back on the held one
        self._force_key: tuple = ()  # (element, state, pose, contact) of the last external force
        self._force_value = NO_FORCE
        self._bearing: tuple[Frame | None, Plate | None, float] = (None, None, 0.0)  # see _plate_on
        self._seen_key, self._seen_views = b"", (ObjectInfo(), ObjectInfo())  # see _seen
        self._untouched = {finger: FingerContact() for finger in FINGERS}  # contacts() with nothing near
        self._touch: tuple = (b"", None, None, {})  # see _touching
        self.collisions: list[str] = []  # "E2 hit E1 at t s", in order
        self.plate_pushes: dict[tuple[str, str], list[float]] = {}  # (element, plate) -> [first t, most N]
        self._t = 0.0
        self._settle(homogeneous(self.arm.pose()).tolist())

    # ----------------------------------------------------------------------------------
    def held(self) -> Element | None:
        for e in self.elements.values():
            if e.state == "held":
                return e
        return None

    def _between_fingers(self, tool: list[list[float]]) -> Element | None:
        """The element held, else the one whose cross-section is between the open fingertips
        (`tool`: the TCP transform's rows)."""
        held = self.held()
        if held is not None:
            return held
        x, y, z, ty = tool[0][3], tool[1][3], tool[2][3], (tool[0][1], tool[1][1], tool[2][1])
        for e in self.elements.values():
            frame = e.frame()
            r = frame.rotation
            if abs(r[1] * ty[0] + r[4] * ty[1] + r[7] * ty[2]) <= 0.9:
                continue  # the fingers do not close across the element width
            local = frame.local(x, y, z)
            if (
                abs(local[0]) <= e.length / 2.0
                and abs(local[1]) <= self.gripper.width() / 2.0
                and abs(local[2]) <= e.depth / 2.0 + self.config.finger_reach
            ):
                return e
        return None

    def step(self, dt: float) -> None:
        self.arm.step(dt)
        tool = homogeneous(self.arm.pose())
        rows = tool.tolist()
        e = self._between_fingers(rows)
        self.gripper.object_width = e.width if e is not None else None
        self.gripper.step(dt)
        if e is not None and e.state != "held" and self.gripper.squeeze_force() > 0.0:
            e.state = "held"
            e.grasp = compose(rigid_inverse(tool), homogeneous(e.pose))
        held = e if e is not None and e.state == "held" else None  # _between_fingers gives a held one first
        if held is not None and self.gripper.squeeze_force() <= 0.0:
            self._release(held)
        elif held is not None:
            self._carry(held, pose_of(compose(tool, held.grasp)))
            if any(self._contact):
                self._slip = 0.3  # the hand drags the held-back element over the pads
            else:
                self._update_slip(held, dt, tool)
        else:
            self._slip = 0.0
        self._t += dt
        self._settle(rows)

    def _carry(self, e: Element, pose: np.ndarray) -> None:
        """Move the held element to `pose`, unless another element is in the way: then it stays
        where it touched, pressed back with the contact stiffness by how far the hand went on."""
        blocker = self._obstacle(e, e.frame(pose))
        if blocker is None:
            e.pose = pose
            self._contact = NO_FORCE
            return
        if not any(self._contact):
            self.collisions.append(f"{e.id} hit {blocker.id} at {self._t:.1f} s")
        k, was, now = self.config.contact_stiffness, e.pose.tolist(), pose.tolist()
        self._contact = (k * (was[0] - now[0]), k * (was[1] - now[1]), k * (was[2] - now[2]))

    def _obstacle(self, e: Element, frame: Frame) -> Element | None:
        """Another element that `e` would overlap in `frame` (their capsules intersect), if any."""
        for other in self.elements.values():
            if other is not e and _capsules_meet(frame, e.width, other.frame(), other.width):
                return other
        return None

    def _settle(self, tool: list[list[float]]) -> None:
        """After a step: what is between the fingers (`tool`: the TCP transform's rows) and the
        (noisy) load the grip carries."""
        self._tool = tool
        self._near = self._between_fingers(tool)
        force = NO_FORCE
        if self._near is not None and self._near.state == "held":
            e, frame = self._near, self._near.frame()
            force = self.external_force(e)
            plate, load = self._plate_on(frame)
            if plate is not None:
                self._watch_push(e, plate, load)
            if plate is not None and self.config.force_noise:
                noise = self._normal(self._load_noise(plate, frame.ends[1]))
                force = (force[0], force[1], force[2] - noise)
        self._force = force
        self.arm.external_wrench = np.array([*force, 0.0, 0.0, 0.0])

    def _release(self, e: Element) -> None:
        bottom, _ = e.ends()
        supported = e.is_upright() and bottom[2] < 0.005
        e.state = "standing" if supported else "dropped"
        if supported:
            e.pose[2] -= bottom[2]  # foot on the ground
        else:
            e.pose = np.array([e.pose[0], e.pose[1], e.depth / 2.0, 0.0, 0.0, 0.0])
        e.grasp = None
        self._slip = 0.3  # the object moves in the fingers as it goes

    # ---- loads ---------------------------------------------------------------------------
    def external_force(self, e: Element) -> Point:
        """Net force (base frame, N) the ground, the plates and gravity put on a held element;
        computed once while the element, its state and the contact force stay as they are (a tick
        asks for it twice when the element does not slip)."""
        frame = e.frame()
        key = (e.id, e.state, frame.key, self._contact)
        if key != self._force_key:
            self._force_key, self._force_value = key, self._external_force(e, frame)
        return self._force_value

    def _external_force(self, e: Element, frame: Frame) -> Point:
        """`external_force` on element `e` in `frame`."""
        bottom = frame.ends[0]
        f0, f1, f2 = 0.0, 0.0, -e.mass * GRAVITY
        if e.state == "held":
            f0, f1, f2 = f0 + self._contact[0], f1 + self._contact[1], f2 + self._contact[2]
        if bottom[2] < 0.0:
            f2 += self.config.ground_stiffness * -bottom[2]
        load = self._plate_on(frame)[1]
        if load:
            f2 -= load
        return f0, f1, f2

    def plate_load(self, e: Element) -> float:
        """True load (N) the plate above puts on element `e`, noise-free."""
        return self._plate_on(e.frame())[1]

    def _plate_on(self, frame: Frame) -> tuple[Plate | None, float]:
        """The plate above an upright element in `frame` (None: none) and the true load it puts on the
        element (N), worked out once per frame, as a held element's tick asks for them twice."""
        if self._bearing[0] is not frame:
            top = frame.ends[1]
            plate = self.plate_above(top) if frame.is_upright() else None
            load = 0.0 if plate is None else plate.beam.carried_force(plate.position_along(top), plate.origin[2] - top[2])
            self._bearing = (frame, plate, load)
        return self._bearing[1], self._bearing[2]

    def plate_above(self, p) -> Plate | None:
        for plate in self.plates.values():
            if plate.position_along(p) is not None:
                return plate
        return None

    def _watch_push(self, e: Element, plate: Plate, load: float) -> None:
        """Note a held element pushing with `load` on a plate it does not prop (dragged under it), or
        pushing any plate harder than the plate weighs (lifting it off its supports)."""
        stray = e.plate and plate.id != e.plate and load > STRAY_LOAD_N
        if stray or load > plate.beam.weight():
            seen = self.plate_pushes.setdefault((e.id, plate.id), [self._t, load])
            seen[1] = max(seen[1], load)

    def _load_noise(self, plate: Plate, top: Point) -> float:
        """Std of the load noise under `plate`: `force_noise` times its true maximum load."""
        if plate.id not in self._noise_scale:
            peak = plate.beam.max_load(plate.origin[2] - top[2])[1]
            self._noise_scale[plate.id] = self.config.force_noise * peak
            if self._noise_scale[plate.id] < 0.0:
                raise ValueError(f"the load noise's std must not be negative (force_noise {self.config.force_noise})")
        return self._noise_scale[plate.id]

    def _normal(self, std: float) -> float:
        """A normal draw with mean 0 and `std` from the scene's generator: `normal(0.0, std)` bit for
        bit (numpy works it out as 0.0 + std z), its standard normal draws z taken NORMAL_DRAWS at a
        time, which gives the same numbers in the same order for a fraction of the cost of a call each."""
        if not self._draws:
            self._draws = self._rng.standard_normal(NORMAL_DRAWS).tolist()[::-1]
        return 0.0 + std * self._draws.pop()

    def _update_slip(self, e: Element, dt: float, tool: np.ndarray) -> None:
        """Let the element slide in the grasp when friction cannot hold the load."""
        f = self.external_force(e)
        r = e.frame().rotation
        along = f[0] * r[0] + f[1] * r[3] + f[2] * r[6]  # along the element axis
        grip = 2.0 * self.config.friction * self.gripper.squeeze_force()
        excess = abs(along) - grip
        if excess <= 0.0:
            self._slip = 0.0
            return
        shift = np.sign(along) * min(0.05, excess / max(grip, 1e-6) * 0.02) * dt
        e.pose[:3] += np.array([r[0], r[3], r[6]]) * shift
        e.grasp = compose(rigid_inverse(tool), homogeneous(e.pose))
        self._slip = min(1.0, 50.0 * abs(shift) / dt * 0.1)
        if abs(e.grasp[0, 3]) + abs(e.grasp[1, 3]) + abs(e.grasp[2, 3]) > e.length / 2.0:
            self._release(e)

    # ---- sensing --------------------------------------------------------------------------
    def _views(self, e: Element, at: Point, tool: list[list[float]], local: Point) -> tuple[ObjectInfo, ObjectInfo]:
        """What the left and right fingertip cameras (tool-y side -1 and +1) see of `e`, whose centre is
        at `at`; `tool` is the TCP transform's rows, `local` the TCP position in the element frame.

        The visible share of the window along the element gives the area and centroid (the same
        share for both fingertips, mirrored); the gap between the element face and each pad scales
        its area (nearer looks bigger).
        """
        r = self.config.view_half
        lo, hi = max(local[0] - r, -e.length / 2.0), min(local[0] + r, e.length / 2.0)
        overlap = max(0.0, hi - lo)
        if overlap <= 0.0:
            return ObjectInfo(), ObjectInfo()
        (_, t01, _, x), (_, t11, _, y), (_, t21, _, z) = tool[:3]
        offset = t01 * (at[0] - x) + t11 * (at[1] - y) + t21 * (at[2] - z)  # element centre, tool y
        half_width = self.gripper.width() / 2.0
        centre = ((lo + hi) / 2.0 - local[0]) / (2.0 * r)  # -0.5 .. 0.5 of the image width
        areas = [0.35 * overlap / (2.0 * r) / (1.0 + max(0.0, half_width - side * offset - e.width / 2.0) / 0.01)
                 for side in SIDES]
        return self._seen(centre, areas)

    def _seen(self, centre: float, areas: list[float]) -> tuple[ObjectInfo, ObjectInfo]:
        """The fingertip views (left, right) of an element seen at `centre` of the image width (the
        left one mirrored) with these `areas`; made again only when one of the three numbers changes
        (compared as their bytes, so that 0.0 and -0.0 differ), as they stay the same while an
        element is held."""
        key = _THREE_FLOATS.pack(centre, *areas)
        if key != self._seen_key:
            left, right = (ObjectInfo(True, area, np.array([side * centre, 0.0]), 0.0) for side, area in zip(SIDES, areas))
            self._seen_key, self._seen_views = key, (left, right)
        return self._seen_views

    def contacts(self) -> dict[str, FingerContact]:
        """Loads and views on the two fingertips for the current state."""
        tool, e = self._tool, self._near
        if e is None:
            return self._untouched
        normal = self.gripper.squeeze_force()
        (t00, _, t02, x), (t10, _, t12, y), (t20, _, t22, z) = tool[:3]
        f0, f1, f2 = self._force  # the element pushes the fingers with the external load
        shear_x, shear_z = 0.5 * (t00 * f0 + t10 * f1 + t20 * f2), 0.5 * (t02 * f0 + t12 * f1 + t22 * f2)
        frame = e.frame()
        return self._touching(normal, shear_x, shear_z, self._views(e, frame.centre, tool, frame.local(x, y, z)))

    def _touching(self, normal: float, shear_x: float, shear_z: float,
                  views: tuple[ObjectInfo, ObjectInfo]) -> dict[str, FingerContact]:
        """The fingertip contacts with these loads (the left one's shear mirrored), `views` and the slip;
        made again only when one of them changes (the loads compared as bytes, the views and the slip
        as the same objects), as they stay the same while an element is carried through the air."""
        key = _THREE_FLOATS.pack(normal, shear_x, shear_z)
        last_key, last_views, last_slip, contacts = self._touch
        if key != last_key or views is not last_views or self._slip is not last_slip:
            contacts = {finger: FingerContact(normal, np.array([side * shear_x, shear_z]), 0.0, None, view, self._slip)
                        for finger, side, view in zip(FINGERS, SIDES, views)}
            self._touch = (key, views, self._slip, contacts)
        return contacts

    def metrics(self) -> dict:
        """The collisions between elements and the plates held elements pushed, when there were any."""
        out = {"collisions": "; ".join(self.collisions)} if self.collisions else {}
        if self.plate_pushes:
            out["plates pushed"] = "; ".join(self._pushes())
        return out

    def _pushes(self) -> list[str]:
        """Each plate a held element pushed that it does not prop, or lifted off its supports."""
        out = []
        for (eid, pid), (t, most) in self.plate_pushes.items():
            plate = self.plates[pid]
            what = ("lifted {} off its supports" if most > plate.beam.weight() else "pushed {}, which it does not prop,")
            out.append(f"{eid} {what.format(pid)} with up to {most:.0f} N from {t:.1f} s")
        return out

    TOLERANCES: ClassVar[dict[str, float]] = {"max_regret": 0.01}  # the force regret (R* - R) / R* a placed element may have

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """Elements that fell when released, pushed a plate they do not prop or lifted one off its
        supports, stand without propping a plate, or prop one with more regret than `max_regret`."""
        truth = self.truth()
        out = [f"{e.id} fell when it was released" for e in self.elements.values() if e.state == "dropped"]
        out += self._pushes()
        out += [f"{eid} stands lifting {t['plate']} off its supports ({t['load_N']:.0f} N > its "
                f"{self.plates[t['plate']].beam.weight():.0f} N)" for eid, t in truth.items()
                if t["load_N"] > self.plates[t["plate"]].beam.weight()]
        out += [f"{e.id} stands but props no plate" for e in self.elements.values()
                if e.state == "standing" and e.id not in truth]
        out += [f"{eid} props {t['plate']} {1000 * (t['position'] - t['true_best_position']):+.0f} mm from the "
                f"true maximum, regret {t['regret'] * 100:.3g} % > {tolerances['max_regret'] * 100:g} %"
                for eid, t in truth.items() if t["regret"] > tolerances["max_regret"]]
        return out

    def stand(self, element_id: str, pose) -> None:
        """Stand an element the as-built model records as placed, at its as-built pose."""
        if element_id in self.elements:
            e = self.elements[element_id]
            e.pose = np.array(pose, float)
            e.state = "standing"

    def truth(self) -> dict[str, dict]:
        """Per element standing under a plate: where it props the plate against the true
        maximum-load position, the load it carries against that maximum, the force regret
        (R* - R) / R*, and the true load curve R(a) along the span at its clearance."""
        out = {}
        for e in self.elements.values():
            if e.state != "standing":
                continue
            top = e.ends()[1]
            plate = self.plate_above(top)
            if plate is None:
                continue
            clearance = plate.origin[2] - top[2]
            a = plate.position_along(top)
            a_best, r_best = plate.beam.max_load(clearance)
            r = float(plate.beam.carried_force(a, clearance))
            along = np.linspace(0.0, plate.beam.span, CURVE_POINTS)
            out[e.id] = {"plate": plate.id, "position": a, "true_best_position": a_best, "load_N": r,
                         "true_max_load_N": r_best, "regret": (r_best - r) / r_best if r_best > 0 else 0.0,
                         "true_load_curve": {"position": along,
                                             "load_N": plate.beam.carried_force(along, clearance)}}
        return out


def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> AssemblyScene:
    """Elements at their pick poses (with seeded placement error) and the plates to prop, their
    loads from the scene file next to the design (`args["design_file"]`), if there is one."""
    rng = np.random.default_rng(seed + 1)
    elements = {}
    for spec in args.get("elements", []):
        length, width, depth = spec["size"]
        pose = np.array(spec["pick_pose"], dtype=float)
        pose[:2] += rng.uniform(-0.008, 0.008, 2)  # where the element really lies
        true_length = length + rng.uniform(-0.003, 0.003)
        mass = randomise.params(Element, "assembly.element", {"mass": spec.get("mass", 0.4)}, world, seed,
                                spec["id"])["mass"]
        elements[spec["id"]] = Element(spec["id"], true_length, width, depth, mass, pose, plate=spec.get("plate", ""))
    design_file = args.get("design_file")
    spans = {spec["id"]: spec["span"] for spec in args.get("plates", [])}
    loads = plate_loads(scene_file_of(Path(design_file)), spans) if design_file else {}
    plates = {}
    for spec in args.get("plates", []):
        beam = BeamPlate(span=spec["span"], **randomise.params(BeamPlate, "assembly.plate", loads.get(spec["id"], {}),
                                                               world, seed, spec["id"]))
        origin = tuple(map(float, spec["origin"]))
        if randomise.enabled(world):  # the supports where they were really built
            shift = randomise.draw("assembly.support", seed, instance=spec["id"])
            origin = tuple(v + shift[d] for v, d in zip(origin, ("dx", "dy", "dz")))
        plates[spec["id"]] = Plate(spec["id"], origin, spec.get("width", 0.3), beam)
    config = SceneConfig(seed=seed, **randomise.params(SceneConfig, "assembly", randomise.scene_config(world), world,
                                                       seed))
    return AssemblyScene(arm, gripper, elements, plates, config)
