"""The press scene (ForceLearn): a stick hangs in a holder between the open fingers, pointing
down along tool z, above an electronic scale. Pressing it on the scale loads the grip along the
stick; the scale reads the contact force with noise (`scale_noise`), which is the label a
learned force model is trained on.

The pads show that load as shear with the partial-slip softening of a Hertz-Mindlin contact:
as the load nears the grip's friction capacity the gel shears more per newton, so the marker
field is not linear in the force (one reason to learn the mapping). Past the capacity the stick
slides up in the grip. The arm's TCP force reads what the stick puts on the hand (its weight once
squeezed, the holder only guiding it, and the scale's push once it touches), as a real arm pressing through its grip feels the press. Let go (no squeeze left), the stick stays upright in its holder, resting
on the scale with its own weight, between the open fingers.

The stick's material (scene arg `object`, `drivers.sim.models.objects`) sets its grip on the pads
(friction, and adhesion: glass sticks), how far the markers move per newton (a soft stick spreads
the load) and how stiff its tip is on the scale, so the marker field per newton depends on the
object pressed, as the paper found for ForceLearn.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.models.objects import GrippedObject
from drivers.sim.scenes import randomise
from drivers.sim.scenes.grip import (
    Grip,
    PickedScene,
    object_grip,
    pad_contacts,
    pad_view,
    slip_signal,
    tool_rotation,
)

GRAVITY = 9.81


def mindlin_shear(load: float, capacity: float) -> float:
    """Elastic-equivalent shear of a partially slipping contact under tangential `load`:
    1.5 c (1 - (1 - |load|/c)^(2/3)), equal to the load when small, 1.5 c at the capacity c."""
    if capacity <= 0.0:
        return 0.0
    ratio = min(abs(load) / capacity, 1.0)
    return float(np.sign(load) * 1.5 * capacity * (1.0 - (1.0 - ratio) ** (2.0 / 3.0)))


def longest_within(values: list[float], target: float, band: float) -> int:
    """The longest run of consecutive `values` within `band` of `target`."""
    longest = run = 0
    for value in values:
        run = run + 1 if abs(value - target) <= band else 0
        longest = max(longest, run)
    return longest


@dataclass
class PressScene(PickedScene):
    PROVIDES: ClassVar[frozenset[str] | None] = frozenset({"surface"})  # for skills' NEEDS
    arm: SceneArm
    gripper: SceneGripper
    mass: float = 0.05  # kg
    width: float = 0.02  # m across the fingers
    length: float = 0.1  # m of stick below the grasp
    scale_gap: float = 0.03  # m from the stick tip down to the scale at the start
    contact_stiffness: float = 4000.0  # N/m, scale platform, stick and pads in series
    scale_noise: float = 0.1  # N, std of the scale reading
    area: float = 0.2
    seed: int = 0
    grip: Grip = field(default_factory=Grip)
    material: GrippedObject | None = None  # the stick's (None: a neutral stick, the cell's friction)

    def __post_init__(self):
        self._dt = 0.0  # s, length of the last tick (slip is motion per camera frame)
        self._rng = np.random.default_rng(self.seed)
        start = self.arm.pose()
        self._start = start[:3]
        self._scale_z = start[2] - self.length - self.scale_gap  # tool z points down at the start
        self.held = False
        self.released = False
        self.force = 0.0  # N the scale pushes the stick up with
        self._load = np.zeros(3)
        self._pressed: list[float] = []  # N on the scale each tick the stick was held (for the verdict)

    def tip(self) -> np.ndarray:
        """Stick tip (base frame)."""
        return self.arm.pose()[:3] + tool_rotation(self.arm)[:, 2] * (self.length + self.grip.slid[1])

    def step(self, dt: float) -> None:
        squeeze = self.carry(dt)
        if squeeze is None:  # squeezed in its holder, which only guides it, the stick's weight is the hand's
            weight = -self.mass * GRAVITY if self.gripper.squeeze_force() > 0.0 else 0.0
            self.arm.external_wrench = np.array([0.0, 0.0, weight, 0.0, 0.0, 0.0])
            return
        if self.released or squeeze <= 0.0:
            self.released = True
            self.force, self._load, self.grip.speed = self.mass * GRAVITY, np.zeros(3), 0.0
            self.arm.external_wrench = np.zeros(6)
            return
        self.force = max(0.0, self.contact_stiffness * (self._scale_z - self.tip()[2]))
        self._pressed.append(self.force)
        on_stick = np.array([0.0, 0.0, self.force - self.mass * GRAVITY])  # base frame: the scale and gravity
        self._load = tool_rotation(self.arm).T @ on_stick
        self.arm.external_wrench = np.r_[on_stick, 0.0, 0.0, 0.0]  # the hand carries the stick: its TCP feels it
        self.grip.step(self._load[[0, 2]], 2 * squeeze, dt)

    def contacts(self):
        squeeze = self.gripper.squeeze_force()
        views = (pad_view(-1.0, self.area, (0.0, 0.0)), pad_view(1.0, self.area, (0.0, 0.0)))
        capacity = self.grip.capacity(2 * squeeze)
        shown = np.array([mindlin_shear(self._load[0], capacity), self._load[1],
                          mindlin_shear(self._load[2], capacity)])
        slip = slip_signal(self.grip.speed, self.area, self._dt)
        gain = self.material.marker_gain if self.material is not None else 1.0
        return pad_contacts((squeeze, squeeze), shown, 0.0, views, slip, gain=gain)

    # how close to the tree's target the scale must read, for how long, and how far the stick may slide
    TOLERANCES: ClassVar[dict[str, float]] = {"force_tolerance_N": 1.0, "min_hold_s": 0.25, "max_slip_mm": 5.0}
    TARGETS: ClassVar[dict[str, str]] = {"press_force_N": "the force the scale must feel, N"}

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """Never picked up, slid in the grip beyond `max_slip_mm`, or (with the tree's target
        `press_force_N`) the scale never read the target within `force_tolerance_N` for `min_hold_s`,
        or, with the stick still pressed at the end, it ends outside that band."""
        if not self.held:
            return ["the stick was never picked up"]
        out = []
        slid = float(abs(self.grip.slid[1])) * 1000
        if slid > tolerances["max_slip_mm"]:
            out.append(f"the stick slid {slid:.1f} mm in the grip > {tolerances['max_slip_mm']:g} mm")
        target = tolerances.get("press_force_N")
        if target is not None:
            band, need = tolerances["force_tolerance_N"], tolerances["min_hold_s"]
            held = longest_within(self._pressed, target, band) * self._dt
            if held < need:
                peak = max(self._pressed, default=0.0)
                out.append(f"the scale never read {target:g} N +- {band:g} N for {need:g} s (peak {peak:.2f} N, "
                           f"longest within {held:.2f} s)")
            elif not self.released and abs(self.force - target) > band:  # the press went on past the target
                out.append(f"the press ends with the scale at {self.force:.2f} N, more than {band:g} N from "
                           f"{target:g} N")
        return out

    def labels(self) -> dict:
        """What the scale says (the training label) and the true force, this tick."""
        reading = self.force + self._rng.normal(0.0, self.scale_noise) if self.held else 0.0
        return {"scale_force": round(reading, 2), "true_force": self.force}

    def label_info(self) -> dict:
        return {"scale_force": {"unit": "N", "noise_std": self.scale_noise, "resolution": 0.01}}

    def metrics(self) -> dict:
        out = {"force on the scale (N)": round(self.force, 3),
               "stick slid in the grip (mm)": round(float(abs(self.grip.slid[1])) * 1000, 2)}
        return {**out, "stick": "released, resting on the scale"} if self.released else out


def build(arm: SceneArm, gripper: SceneGripper, args: dict, world: dict, seed: int) -> PressScene:
    """Scene args: mass (kg), contact_stiffness (N/m; default the object's), scale_noise (N),
    object (wood, glass, rubber, foam, steel; default a neutral stick with the cell's friction)."""
    grip, material = object_grip(args, world)
    given = {"mass": args.get("mass", 0.05),
             "contact_stiffness": args.get("contact_stiffness", material.stiffness if material else 4000.0),
             "scale_noise": args.get("scale_noise", 0.1)}
    return PressScene(arm, gripper, **randomise.params(PressScene, "press", given, world, seed), seed=seed,
                      grip=grip, material=material)
