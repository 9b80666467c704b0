"""The FollowMe scene: a person holds a block between the open fingers; a second after the
robot has grasped it, the person leads it along one tool axis (pull: +axis, push: -axis) on a
minimum-jerk path and holds it there. The person's arm is a spring (stiffness `hand_stiffness`,
force capped at `max_force`) pulling the block towards the scripted path; the block reaches the
hand through the gel (elastic shear, then sliding beyond friction) and, along the closing axis,
through the pads' normal stiffness. The cameras see the block shift along the pads (centroid,
with noise). Along the closing axis the block cannot shift in the view: its face touches the skin,
so all a camera can see of a push is the block coming nearer as the gel under it compresses (and
going away as the other pad's gel relaxes). Each camera sees through the skin with a lens
`camera_depth` behind the skin's surface; a pad under a normal load N is compressed by
N / `pad_stiffness`, so the block's apparent area is `area` (at the grasp's own squeeze) times
(d_grasp / d)^2 with d = camera_depth - N / pad_stiffness (a pinhole; the blur does not change, the
block's face stays on the skin where the camera is focused). With the defaults a newton of push
(half a newton more on one pad, half less on the other) changes the area each pad sees by about 1 %:
this, not a growing contact patch, is the cue vision has along the axis perpendicular to the skin
(docs/physics.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.models.objects import GrippedObject
from drivers.sim.scenes import randomise
from drivers.sim.scenes.base import Scene
from drivers.sim.scenes.grip import (
    Grip,
    empty_contacts,
    object_grip,
    pad_contacts,
    pad_view,
    slip_signal,
    step_hand,
    tool_rotation,
)

AXES = "xyz"


def min_jerk(s: float) -> float:
    """Minimum-jerk profile 0 -> 1 for s in [0, 1]."""
    s = min(max(s, 0.0), 1.0)
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


@dataclass
class FollowMeScene(Scene):
    PROVIDES: ClassVar[frozenset[str] | None] = frozenset({"leader"})  # for skills' NEEDS
    arm: SceneArm
    gripper: SceneGripper
    axis: str = "x"
    direction: str = "pull"
    distance: float = 0.12  # m the person leads the block
    move_time: float = 4.0  # s
    start_delay: float = 1.0  # s after the grasp
    width: float = 0.04  # m block width across the fingers
    hand_stiffness: float = 300.0  # N/m, the person's arm
    max_force: float = 25.0  # N a person is willing to push or pull with
    area: float = 0.3  # share of each camera image the block covers
    view_half: float = 0.015  # m, half the camera window along the pads
    pad_reach: float = 0.02  # m the block may slide along the pads before it leaves them
    vision_noise: float = 0.01  # std of the centroid, image fraction
    # FingerVision's camera sits behind an acrylic plate and the gel; no published figure for the lens-to-
    # skin distance: 20 mm (range 15-30 mm) is the depth of a fingertip that fits a parallel gripper.
    camera_depth: float = 0.02  # m
    pad_stiffness: float = 5000.0  # N/m, one pad's gel along its normal (the simulated gripper's 2500 N/m
    # squeeze per metre of closing is two such gels in series)
    seed: int = 0
    grip: Grip = field(default_factory=Grip)
    material: GrippedObject | None = None  # the block's (None: neutral, the cell's friction)

    def __post_init__(self):
        self._dt = 0.0  # s, length of the last tick (slip is motion per camera frame)
        if self.axis not in AXES or self.direction not in ("pull", "push"):
            raise ValueError(f"followme needs axis in x/y/z and direction pull/push, got "
                             f"{self.axis!r}, {self.direction!r}")
        self._rng = np.random.default_rng(self.seed)
        self._tcp0 = self.arm.pose()[:3]
        self._rot0 = tool_rotation(self.arm)
        sign = 1.0 if self.direction == "pull" else -1.0
        self._lead = self._rot0[:, AXES.index(self.axis)] * sign * self.distance  # base frame
        self._t = 0.0
        self._grasped_at: float | None = None
        self.lost = False
        self._force = np.zeros(3)  # person's force on the block, tool frame
        self._offset = np.zeros(2)  # block relative to the grasp, tool x and z
        self._seen_speed = 0.0
        self._errors: list[float] = []
        self._velocities: list[np.ndarray] = []
        self._peak_force = 0.0

    def hand_target(self) -> np.ndarray:
        """Where the person's hand wants the block (base frame)."""
        if self._grasped_at is None:
            return self._tcp0
        return self._tcp0 + self._lead * min_jerk((self._t - self._grasped_at - self.start_delay) / self.move_time)

    def step(self, dt: float) -> None:
        self._dt = dt
        step_hand(self.arm, self.gripper, None if self.lost else self.width, dt)
        self._t += dt
        squeeze = self.gripper.squeeze_force()
        if self._grasped_at is None and squeeze > 0.0:
            self._grasped_at = self._t
        if self._grasped_at is None or self.lost:
            return
        rot = tool_rotation(self.arm)
        tcp = self.arm.pose()[:3]
        ahead = rot.T @ (self.hand_target() - tcp)  # tool frame
        # Along the pads the person's spring and the gel shear act in series, on top of sliding.
        tangential = self.hand_stiffness * (ahead[[0, 2]] - self.grip.slid)
        tangential /= 1.0 + self.hand_stiffness / self.grip.shear_stiffness
        # Along the closing axis the pads are far stiffer than the person: the block stays put.
        force = np.array([tangential[0], self.hand_stiffness * ahead[1], tangential[1]])
        magnitude = float(np.linalg.norm(force))
        if magnitude > self.max_force:
            force *= self.max_force / magnitude
        self._force = force
        self.grip.step(force[[0, 2]], 2.0 * squeeze, dt)
        offset = self.grip.offset(force[[0, 2]])
        self._seen_speed = float(np.hypot(*(offset - self._offset))) / dt
        self._offset = offset
        if np.max(np.abs(offset)) > self.pad_reach:
            self.lost = True
        self._record(tcp, dt)

    def _record(self, tcp: np.ndarray, dt: float) -> None:
        if self._t - self._grasped_at < self.start_delay:
            return
        self._errors.append(float(np.linalg.norm((tcp - self._tcp0) - (self.hand_target() - self._tcp0))))
        self._velocities.append(self.arm.tcp_speed()[:3])
        self._peak_force = max(self._peak_force, float(np.linalg.norm(self._force)))

    def normals(self) -> tuple[float, float]:
        """(left, right) pad loads: the squeeze, shifted by the person's push along tool y."""
        squeeze = self.gripper.squeeze_force()
        return squeeze - 0.5 * self._force[1], squeeze + 0.5 * self._force[1]

    def contacts(self):
        if self.lost:
            return empty_contacts()
        if self._grasped_at is None:
            return self._open_contacts()
        centroid = self._offset / (2 * self.view_half) + self._rng.normal(0.0, self.vision_noise, 2)
        normals = self.normals()
        views = tuple(pad_view(side, self.pressed_area(normal), centroid) for side, normal in zip((-1.0, 1.0), normals))
        slip = slip_signal(self._seen_speed, self.area, self._dt)
        gain = self.material.marker_gain if self.material is not None else 1.0
        return pad_contacts(normals, self._force, 0.0, views, slip, gain=gain)

    def pressed_area(self, normal: float) -> float:
        """Share of a pad's image the block covers under `normal` N (signed: below 0 the block has left
        the gel by -normal / pad_stiffness): `area` at the grasp's own squeeze, scaled by the square of
        how much nearer the block is to the camera than then."""
        squeeze = self.gripper.squeeze_force()
        near = self.camera_depth - squeeze / self.pad_stiffness  # lens to the block's face at the grasp
        now = max(self.camera_depth - normal / self.pad_stiffness, 0.2 * self.camera_depth)
        return min(self.area * (near / now) ** 2, 1.0)

    def _open_contacts(self):
        """Before the grasp: the block is seen between the open fingers, nothing touches."""
        views = (pad_view(-1.0, self.area, (0.0, 0.0)), pad_view(1.0, self.area, (0.0, 0.0)))
        return pad_contacts((0.0, 0.0), np.zeros(3), 0.0, views)

    # how far from the person's hand the tool may end, and may be on average while led
    TOLERANCES: ClassVar[dict[str, float]] = {"max_final_error_mm": 20.0, "max_rms_error_mm": 25.0}

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """Lost, never grasped, let go of before the person's lead was over, or tracked with more
        error than `max_rms_error_mm` on average or `max_final_error_mm` at the end."""
        if self.lost:
            return ["the block was lost"]
        if self._grasped_at is None:
            return ["the block was never grasped, so the person never led it"]
        out = []
        led = self._t - self._grasped_at - self.start_delay
        if led < self.move_time:
            out.append(f"the run ended {max(led, 0.0):.1f} s into the person's {self.move_time:g} s lead")
        if self._errors:
            final = self._errors[-1] * 1000
            rms = float(np.sqrt(np.mean(np.square(self._errors)))) * 1000
            if final > tolerances["max_final_error_mm"]:
                out.append(f"the tool ended {final:.1f} mm from the block's goal > {tolerances['max_final_error_mm']:g} mm")
            if rms > tolerances["max_rms_error_mm"]:
                out.append(f"the tool tracked the block with {rms:.1f} mm rms error > "
                           f"{tolerances['max_rms_error_mm']:g} mm")
        return out

    def metrics(self) -> dict:
        if not self._errors:
            return {"person led the block": False}
        v = np.array(self._velocities)
        dt = self._dt
        jerk = np.diff(v, n=2, axis=0) / dt**2 if len(v) > 2 else np.zeros((1, 3))
        return {"tracking error rms (mm)": round(float(np.sqrt(np.mean(np.square(self._errors)))) * 1000, 2),
                "tracking error final (mm)": round(self._errors[-1] * 1000, 2),
                "command jerk rms (m/s^3)": round(float(np.sqrt(np.mean(np.sum(jerk**2, axis=1)))), 3),
                "peak force on the block (N)": round(self._peak_force, 2),
                "block lost": self.lost}


def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> FollowMeScene:
    """Scene args: axis (x|y|z, tool axes), direction (pull|push), distance (m), move_time (s),
    object (wood, glass, rubber, foam, steel; default a neutral block with the cell's friction)."""
    grip, material = object_grip(args, world)
    given = {"distance": args.get("distance", 0.12), "move_time": args.get("move_time", 4.0)}
    return FollowMeScene(arm, gripper, axis=args.get("axis", "x"), direction=args.get("direction", "pull"),
                         **randomise.params(FollowMeScene, "followme", given, world, seed),
                         seed=seed, grip=grip, material=material)
