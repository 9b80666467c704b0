"""Object-dependent contact (drivers/sim/models/objects.py): what the gripped object is made of sets
its grip on the pads and how far the markers move per newton in the press, hold and followme scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivers.clock import SimClock
from drivers.sim.devices.arm import KinematicArm
from drivers.sim.devices.gripper import SimGripper
from drivers.sim.models.objects import GEL_MODULUS, GEL_POISSON, OBJECTS, gripped_object
from drivers.sim.scenes import SCENES

HOME = [0.0, 0.0, 0.5, math.pi, 0.0, 0.0]
DT = 1 / 30


def test_a_softer_object_spreads_the_load_as_a_hertz_contact_does():
    rigid = GEL_MODULUS / (1 - GEL_POISSON**2)
    for o in OBJECTS.values():
        e_star = 1 / ((1 - GEL_POISSON**2) / GEL_MODULUS + (1 - o.poisson**2) / o.modulus)
        assert o.marker_gain == pytest.approx((e_star / rigid) ** (1 / 3))
    gains = {name: o.marker_gain for name, o in OBJECTS.items()}
    assert gains["foam"] < 0.4 < gains["rubber"] < gains["wood"] <= 1.0
    assert gains["glass"] == pytest.approx(1.0, abs=1e-3)


def test_an_unknown_object_names_the_known_ones():
    with pytest.raises(ValueError, match="known: foam, glass, rubber, steel, wood"):
        gripped_object("jelly")
    assert gripped_object(None) is None


def pressed(scene_name: str, obj: str | None, press_mm: float) -> dict:
    """The press scene's contacts after grasping the stick with 10 N, lifting it and pressing its
    tip `press_mm` into the scale."""
    arm, gripper = KinematicArm(SimClock(DT), HOME), SimGripper(gel_stiffness=5000.0)
    world = SCENES[scene_name](arm, gripper, {} if obj is None else {"object": obj}, {}, 0)
    gripper.move(0.0, speed=0.1, force=10.0)
    for _ in range(30):
        world.step(DT)
    down = HOME[2] - 0.03 - press_mm / 1000  # the scale is 30 mm below the stick's tip
    arm.move_linear(np.array([0.0, 0.0, HOME[2] + 0.003, *HOME[3:]]), 0.05)
    for _ in range(10):
        world.step(DT)
    arm.move_linear(np.array([0.0, 0.0, down, *HOME[3:]]), 0.05)
    for _ in range(60):
        world.step(DT)
    return world.contacts()


def test_the_press_scene_shows_a_load_per_object():
    shear = {o: abs(pressed("press", o, 1.0)["left"].shear[1]) for o in ("wood", "foam", "glass", "rubber")}
    neutral = abs(pressed("press", None, 1.0)["left"].shear[1])
    assert shear["wood"] == pytest.approx(neutral, rel=1e-3)  # wood is the cells' former stick (near rigid)
    # foam: a soft tip (less force for the same travel) and the load spread over a larger patch
    assert shear["foam"] < 0.2 * shear["wood"]
    assert shear["rubber"] < shear["wood"]


def test_glass_sticks_where_wood_slips():
    """Pressed 6 mm (about 24 N on the scale against a 10 N squeeze) a wooden stick slides up in the
    grip, a glass one, gripped by friction 1.6 and adhesion, does not."""
    slid = {}
    for obj in ("wood", "glass"):
        arm, gripper = KinematicArm(SimClock(DT), HOME), SimGripper(gel_stiffness=5000.0)
        world = SCENES["press"](arm, gripper, {"object": obj}, {}, 0)
        gripper.move(0.0, speed=0.1, force=10.0)
        for _ in range(30):
            world.step(DT)
        arm.move_linear(np.array([0.0, 0.0, HOME[2] - 0.036, *HOME[3:]]), 0.05)
        for _ in range(80):
            world.step(DT)
        slid[obj] = world.metrics()["stick slid in the grip (mm)"]
    assert slid["wood"] > 1.0 and slid["glass"] == 0.0


@pytest.mark.parametrize("scene", ["hold", "followme"])
def test_the_held_scenes_take_the_object_too(scene):
    arm, gripper = KinematicArm(SimClock(DT), HOME), SimGripper(gel_stiffness=5000.0)
    world = SCENES[scene](arm, gripper, {"object": "glass"}, {"friction": 0.3}, 0)
    assert world.grip.friction == 1.6 and world.grip.adhesion == 3.0  # the object's, not the cell's
    world = SCENES[scene](arm, gripper, {}, {"friction": 0.3}, 0)
    assert world.grip.friction == 0.3 and world.grip.adhesion == 0.0
