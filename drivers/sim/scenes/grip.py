"""Physics shared by the scenes whose object is held between the two FingerVision pads:
Coulomb grip with an elastic gel, sliding once the load beats friction, and the per-finger
contacts and camera views the sensor model turns into TactileStates.

Frames as in the assembly scene: the gripper closes along tool y (right finger at +y); each finger's
image x runs along tool x (mirrored on the left finger) and image y along tool z. A torque about
tool y therefore turns the two images in opposite senses.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from drivers.protocols import SceneArm, SceneGripper
from drivers.sim.models.fingervision_model import FingerContact
from drivers.sim.models.objects import GrippedObject, gripped_object
from drivers.sim.scenes.base import Scene
from drivers.sim.transforms import rotvec_to_matrix
from perception.state import ObjectInfo

SIDES = (("left", -1.0), ("right", 1.0))
SLIP_TRAVEL = 0.002  # m per frame at which a moving object lights its whole visible area


def tool_rotation(arm: SceneArm) -> np.ndarray:
    """3x3 rotation of the TCP; column i is tool axis i in the base frame."""
    return rotvec_to_matrix(arm.pose()[3:])


def step_hand(arm: SceneArm, gripper: SceneGripper, object_width: float | None, dt: float) -> float:
    """Integrate arm and gripper for one tick with an object `object_width` wide (None: nothing)
    between the pads; returns the squeeze the gels put on it (N)."""
    arm.step(dt)
    gripper.object_width = object_width
    gripper.step(dt)
    return gripper.squeeze_force()


def picked_up(arm: SceneArm, start: np.ndarray, squeeze: float) -> bool:
    """A squeezed object counts as held once the hand has carried it 2 mm from `start`."""
    return squeeze > 0.0 and float(np.linalg.norm(arm.pose()[:3] - start)) > 0.002


def slip_signal(speed: float, area: float, dt: float) -> float:
    """Per-finger slip (mv_s scale): the share of the visible object area that changes between
    frames, full once the object moves SLIP_TRAVEL per frame."""
    return area * min(1.0, abs(speed) * dt / SLIP_TRAVEL)


def pad_view(side: float, area: float, centroid_xz, orientation: float = 0.0) -> ObjectInfo:
    """What the pad camera on `side` sees, given the object's centroid (image fractions along
    tool x and z) and its orientation in the tool x-z plane (rad)."""
    if area <= 0.0:
        return ObjectInfo()
    return ObjectInfo(True, area, np.array([side * centroid_xz[0], centroid_xz[1]]), side * orientation)


def pad_contacts(normals: tuple[float, float], load, torque_y: float = 0.0,
                 views: tuple[ObjectInfo, ObjectInfo] = (ObjectInfo(), ObjectInfo()),
                 slip: float = 0.0, centre=None, gain: float = 1.0) -> dict[str, FingerContact]:
    """FingerContacts of both pads: `normals` (left, right) in N, `load` the force the object
    puts on the hand in tool axes (x and z shared equally as shear), `torque_y` (N m) the
    torque it puts on the hand about tool y, `views` (left, right), `slip` per finger, and
    `centre` the contact patch centre in image pixels (None: the image centre). `gain` scales the
    loads the gel shows: an object softer than the gel spreads them (`GrippedObject.marker_gain`)."""
    out = {}
    for (finger, side), normal, view in zip(SIDES, normals, views):
        shear = np.array([0.5 * side * load[0], 0.5 * load[2]]) * gain
        out[finger] = FingerContact(max(normal, 0.0) * gain, shear, -side * 0.5 * torque_y * gain, centre, view, slip)
    return out


def empty_contacts() -> dict[str, FingerContact]:
    return {"left": FingerContact(), "right": FingerContact()}


@dataclass
class Grip:
    """Tangential contact of a held object with both pads, in tool (x, z): elastic gel shear
    up to friction, then sliding at a speed set by the force beyond friction."""

    friction: float = 0.8
    shear_stiffness: float = 2000.0  # N/m, both pads together
    slide_damping: float = 150.0  # N s/m
    slid: np.ndarray = field(default_factory=lambda: np.zeros(2))  # m since grasped
    speed: float = 0.0  # sliding speed of the last step, m/s
    adhesion: float = 0.0  # N carried beyond friction while squeezed (a sticky surface: glass)

    def capacity(self, normal_total: float) -> float:
        """Largest tangential load (N) the grip carries without sliding."""
        return self.friction * max(normal_total, 0.0) + (self.adhesion if normal_total > 0.0 else 0.0)

    def step(self, load, normal_total: float, dt: float) -> None:
        """Slide under `load` (N on the object, tool x and z) where it beats friction."""
        load = np.asarray(load, float)
        magnitude = float(np.hypot(load[0], load[1]))
        excess = magnitude - self.capacity(normal_total)
        self.speed = excess / self.slide_damping if excess > 0.0 else 0.0
        if self.speed:
            self.slid = self.slid + load / magnitude * self.speed * dt

    def offset(self, load) -> np.ndarray:
        """Object position relative to where it was grasped: slid plus elastic gel shear (m)."""
        return self.slid + np.asarray(load, float) / self.shear_stiffness


def object_grip(args: dict, world: dict) -> tuple[Grip, GrippedObject | None]:
    """The grip on the object the scene arg `object` names (`drivers.sim.models.objects`: its
    friction and adhesion), or, without one, on a neutral object with the cell's world friction."""
    obj = gripped_object(args.get("object"))
    if obj is None:
        return Grip(friction=world.get("friction", 0.8)), None
    return Grip(friction=obj.friction, adhesion=obj.adhesion), obj


class PickedScene(Scene):
    """A scene whose object (`width` wide, lying at `_start`) counts only once the hand has
    squeezed it and carried it away: the press and stir sticks."""

    def carry(self, dt: float) -> float | None:
        """Step arm and gripper around the object; its squeeze once picked up, None before."""
        self._dt = dt
        squeeze = step_hand(self.arm, self.gripper, self.width, dt)
        if not self.held:
            self.held = picked_up(self.arm, self._start, squeeze)
            return None
        return squeeze
