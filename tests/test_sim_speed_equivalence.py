"""The shortcuts that make the simulated cell and the recorder cheaper give the same values, bit for bit, as
the general path: an unloaded fingertip's shared rest field, and the recorder's marker arrows built per batch.

The per-tick models of the simulated cell (the fingertip skin, the TCP force sensor, the arm's sub-steps)
run on Python floats, cached factors and matrices and blocks of random draws, because numpy's cost per call is many times the arithmetic on a
handful of numbers: each is driven here beside a plain numpy form of the same model (as its docstring
states it) through the same seeded inputs, and must give the same floats."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from drivers.clock import SimClock
from drivers.sim.devices.arm import KinematicArm
from drivers.sim.devices.arm_motion import ArmMotion
from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from drivers.sim.models.force_sensor import NOISE_DRAWS, ForceSensedArm, ForceSensorConfig, _unit
from drivers.sim.models.skin import REST, Skin
from drivers.sim.transforms import rotvec_to_matrix
from perception.sensor_profile import default_profile
from perception.state import ObjectInfo


def _contacts() -> list[FingerContact]:
    """Unloaded ticks around loaded ones (some with the object in view), past one random-number block."""
    unloaded = [FingerContact() for _ in range(150)]
    seen = ObjectInfo(True, 0.2, np.array([0.1, -0.05]), 0.3)
    loaded = [FingerContact(2.0 + 0.1 * i, np.array([0.3 * i, -0.2]), 0.001 * i, None, seen, 0.01 * i)
              for i in range(5)]
    sideways = [FingerContact(0.0, np.array([-0.0, 0.0]), 0.0, None, seen, 0.02)]  # no load, the object in view
    return unloaded + loaded + sideways * 3 + unloaded + loaded[:2]


def _same(a, b) -> None:
    for x, y in ((a.markers.position, b.markers.position), (a.markers.size, b.markers.size),
                 (a.markers.valid, b.markers.valid), (a.force, b.force), (a.torque, b.torque),
                 (a.obj.centroid, b.obj.centroid)):
        assert np.array_equal(x, y)
    assert (a.slip, a.obj.present, a.obj.area, a.obj.orientation) == (b.slip, b.obj.present, b.obj.area,
                                                                         b.obj.orientation)


@pytest.mark.parametrize("errors", [True, False])
def test_an_unloaded_fingertip_gives_the_states_of_the_general_path(errors):
    shortcut = SensorModel("left", seed=3, pipeline_errors=errors)
    general = SensorModel("left", seed=3, pipeline_errors=errors)
    general._exact = general._loaded  # every tick through the product with the contact basis
    states = []
    for k, contact in enumerate(_contacts()):
        a, b = shortcut.state(contact, 0.01 * k), general.state(contact, 0.01 * k)
        _same(a, b)
        states.append(a)
    assert states[0].markers.position is not states[1].markers.position  # never one array handed out twice
    assert not np.array_equal(states[0].markers.position, states[1].markers.position)  # noise on the rest field


# ---- the skin ---------------------------------------------------------------------------------


class ReferenceSkin:
    """The skin as its module docstring writes it, on numpy arrays: two first-order branches per
    load channel, slower while a channel unloads."""

    def __init__(self, lag: float, creep_share: float, creep_time: float, hysteresis: float):
        self.lag, self.creep_time, self.hysteresis = lag, creep_time, hysteresis
        self.creep_share = creep_share if creep_time > 0.0 else 0.0
        self.fast, self.slow, self.last = np.zeros(4), np.zeros(4), None

    def felt(self, contact: FingerContact, now: float) -> np.ndarray:
        load = np.array([contact.normal, contact.shear[0], contact.shear[1], contact.torque], float)
        dt = 0.0 if self.last is None else max(now - self.last, 0.0)
        if self.last is None:
            self.fast[:] = self.slow[:] = 0.0 if self.lag > 0.0 else load
        self.last = now
        for state, tau in ((self.fast, self.lag), (self.slow, self.creep_time)):
            if tau <= 0.0:
                state[:] = load
                continue
            taus = np.where(np.abs(load) < np.abs(state), tau * (1.0 + self.hysteresis), tau)
            state += (load - state) * (1.0 - np.exp(-dt / taus))
        felt = (1.0 - self.creep_share) * self.fast + self.creep_share * self.slow
        felt[np.abs(felt) < REST] = 0.0
        return felt


def _loads(rng: np.random.Generator, ticks: int) -> list[FingerContact]:
    """Contacts that load, hold, reverse and release: steps, ramps and noise on every channel."""
    contacts, level = [], np.zeros(4)
    for t in range(ticks):
        if t % 40 == 0:  # a new step: sometimes a release to nothing
            level = np.zeros(4) if rng.random() < 0.25 else rng.normal(0.0, [10.0, 3.0, 3.0, 0.05])
        load = level + rng.normal(0.0, [0.2, 0.05, 0.05, 0.001]) * (rng.random() < 0.5)
        contacts.append(FingerContact(float(load[0]), load[1:3].copy(), float(load[3])))
    return contacts


SKINS = {"default": {}, "hysteresis": {"skin_hysteresis": 1.5}, "no lag, creep": {"skin_lag_s": 0.0},
         "lag only": {"skin_creep_share": 0.0}, "slow": {"skin_lag_s": 1.0, "skin_creep_s": 10.0}}


@pytest.mark.parametrize("name", SKINS)
def test_the_skin_feels_what_its_array_form_feels_bit_for_bit(name: str):
    profile = dataclasses.replace(default_profile(), **SKINS[name])
    skin, reference = Skin(profile), ReferenceSkin(profile.skin_lag_s, profile.skin_creep_share,
                                                   profile.skin_creep_s, profile.skin_hysteresis)
    clock = SimClock(1.0 / 30.0)  # its steps carry different rounding: the skin caches per step
    unchanged = 0
    for contact in _loads(np.random.default_rng(7), 600):
        now = clock.now()
        felt, expected = skin.feel(contact, now), reference.felt(contact, now)
        got = [felt.normal, *felt.shear.tolist(), felt.torque]
        assert got == expected.tolist()
        assert (felt.centre, felt.obj, felt.slip) == (contact.centre, contact.obj, contact.slip)
        unchanged += felt is contact
        clock.advance()
    if name == "no lag, creep":
        assert unchanged == 0  # the creep shows on every loaded tick
    assert skin._steps and len(skin._steps) <= 16  # the clock's steps: a handful of values


def test_an_unloaded_skin_hands_on_the_contact_itself():
    skin, contact = Skin(default_profile()), FingerContact()
    assert all(skin.feel(contact, t / 30.0) is contact for t in range(5))


# ---- the TCP force sensor ---------------------------------------------------------------------


class ReferenceForceSensor:
    """`ForceSensedArm`'s reading on arrays, its noise drawn a tick at a time."""

    def __init__(self, arm: KinematicArm, clock: SimClock, config: ForceSensorConfig, seed: int):
        self.arm, self.clock, self.config = arm, clock, config
        self.rng = np.random.default_rng([seed, 0xF7])
        self.offset, self.drift, self.bias = np.zeros(6), np.zeros(6), np.zeros(6)
        self.offset[:3] = config.offset * _unit(self.rng)
        self.drift[:3] = config.drift / 60.0 * _unit(self.rng)
        self.tick: tuple[float, np.ndarray] | None = None

    def error(self) -> np.ndarray:
        now = self.clock.now()
        if self.tick is None or self.tick[0] != now:
            noise = np.zeros(6)
            if self.config.noise:
                noise[:3] = self.config.noise * self.rng.standard_normal(3)
            self.tick = (now, self.offset + self.drift * now + noise)
        return self.tick[1]

    def tcp_wrench(self) -> np.ndarray:
        return self.arm.tcp_wrench() + self.error() - self.bias

    def zero(self) -> None:
        self.bias = self.arm.tcp_wrench() + self.error()


@pytest.mark.parametrize("config", [ForceSensorConfig(), ForceSensorConfig(noise=0.0),
                                    ForceSensorConfig(offset=10.0, drift=2.0, noise=3.6)])
def test_the_force_sensor_reads_what_its_array_form_reads_bit_for_bit(config: ForceSensorConfig):
    clock = SimClock(1.0 / 30.0)
    arm = KinematicArm(clock, np.array([0.0, 0.0, 0.5, np.pi, 0.0, 0.0]))
    sensed, reference = ForceSensedArm(arm, clock, config, seed=3), ReferenceForceSensor(arm, clock, config, seed=3)
    rng = np.random.default_rng(11)
    for tick in range(3 * NOISE_DRAWS + 5):  # across blocks of draws
        arm.external_wrench = rng.normal(0.0, 20.0, 6) * (rng.random() < 0.7)
        if tick % 97 == 5:
            sensed.zero_ft_sensor()
            reference.zero()
        for _ in range(1 + tick % 3):  # several readers a tick see one value
            got, expected = sensed.tcp_wrench(), reference.tcp_wrench()
            assert got.dtype == expected.dtype and got.tolist() == expected.tolist()
        clock.advance()


# ---- the arm ----------------------------------------------------------------------------------


class UncachedArm(KinematicArm):
    """The arm with the goal's and the pose's rotation matrices made again on every sub-step."""

    def _rotation_left(self, pose, target, turn):
        self._start_rotation, self._goal_rotation = None, rotvec_to_matrix(target[3:6])
        return super()._rotation_left(pose, target, turn)


def test_the_arm_turns_as_with_its_rotations_made_every_sub_step():
    clock = SimClock(1.0 / 30.0)
    home = np.array([0.1, -0.2, 0.5, np.pi, 0.0, 0.0])
    arms = [KinematicArm(clock, home, motion=ArmMotion()), UncachedArm(clock, home, motion=ArmMotion())]
    rng = np.random.default_rng(5)
    for tick in range(900):
        if tick % 150 == 0:  # a move that turns (near a half turn, where rounding matters most)
            goal = arms[0].pose() + np.r_[rng.normal(0.0, 0.08, 3), rng.normal(0.0, 0.3, 3)]
            goal[3:] *= min(1.0, np.pi / np.linalg.norm(goal[3:]))
            commands = [("move_linear", goal, 0.15)]
        elif tick % 150 == 100:
            commands = [("speed_linear", np.r_[rng.normal(0.0, 0.05, 3), 0.0, 0.0, 0.2])]
        elif tick % 150 == 130:
            commands = [("stop",)]
        else:
            commands = []
        for arm in arms:
            for name, *args in commands:
                getattr(arm, name)(*args)
            arm.step(clock.period)
        assert arms[0].pose().tobytes() == arms[1].pose().tobytes()
        assert arms[0].tcp_speed().tobytes() == arms[1].tcp_speed().tobytes()
        clock.advance()
    assert arms[0].is_moving() == arms[1].is_moving()
