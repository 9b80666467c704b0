"""The workspace box holds under every command (issue: a held twist drove the TCP 350 mm under the
box's floor): the safety layer checks a twist when it is commanded and again every control period
while it is held, one period ahead. Every registered skill is driven here with adversarial
perception (hypothesis draws the sequence of what the fingertips feel) on a cell whose box is a few
centimetres around the start, and the TCP must stay inside it on every tick; the descent that found
nothing below stops at the floor and says so."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from assembly.testing import TreeHarness, mock_cell, touch
from assembly.testing.harness import HOME
from assembly.testing.skill_checks import ELEMENT, FELT, PLATES, TREE_FILE, felt, tree_text
from behaviours.skill_kit import keys
from behaviours.skill_kit.registry import SKILLS
from drivers.safety import SafetyLimits

TICK_HZ = 10
TICKS = 400  # 40 s of cell time per example: most skills end well before
HALF = 0.03  # m: the box is HOME +- 3 cm on every axis
BOX = SafetyLimits(workspace_min=HOME[:3] - HALF, workspace_max=HOME[:3] + HALF)
NOTHING = {f: touch(f) for f in ("left", "right")}
FEELINGS = [*FELT, "nothing"]
NEEDED = {"move_to": {"offset": [0.0, 0.0, -0.2]}}  # a move_to needs an offset: one through the floor


def harness(skill: str, limits: SafetyLimits, tick_hz: float = TICK_HZ, params: dict | None = None) -> TreeHarness:
    """`skill` alone in a tree on a mocked cell (an object between the fingers) with the box `limits`."""
    cell = mock_cell(tick_hz, gripper_width=0.06, object_width=0.04, limits=limits)
    given_params = {**NEEDED.get(skill, {}), **(params or {})}
    h = TreeHarness.from_text(tree_text(skill, given_params), cell=cell, name=TREE_FILE)
    h.set(keys.ELEMENT, copy.deepcopy(ELEMENT))
    h.set(keys.PLATES, copy.deepcopy(PLATES))
    return h


def outside(pose: np.ndarray, limits: SafetyLimits) -> bool:
    return bool(np.any(pose[:3] < limits.workspace_min - 1e-9) or np.any(pose[:3] > limits.workspace_max + 1e-9))


@pytest.mark.parametrize("skill", sorted(SKILLS))
@settings(max_examples=4, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(feelings=st.lists(st.sampled_from(FEELINGS), min_size=1, max_size=12), hold=st.integers(1, 20))
def test_no_skill_drives_the_tcp_out_of_the_box(skill, feelings, hold):
    """Each tick the fingertips feel the next entry of `feelings` (each for `hold` ticks, cycling)."""
    h = harness(skill, BOX).script(
        lambda tick, t: NOTHING if (name := feelings[tick // hold % len(feelings)]) == "nothing" else felt(name))
    h.cell.estop = SKILLS[skill].RUNS_UNTIL_HALTED  # what keeps estop_guard running
    for _ in range(TICKS):
        status = h.tick()
        pose = h.arm.pose()
        assert not outside(pose, BOX), (f"{skill} took the TCP to {np.round(pose[:3], 4).tolist()}, outside "
                                        f"{BOX.workspace_min.tolist()} .. {BOX.workspace_max.tolist()}")
        if status.name != "RUNNING":
            break


@pytest.mark.parametrize("tick_hz", [30, 2])
def test_a_descent_with_nothing_below_stops_at_the_floor_and_says_so(tick_hz):
    """The reproducer: floor 5 cm below the start, no contact, max_travel 0.15 m (before: the TCP
    ended 350 mm under the floor at 30 Hz, 400 mm at 2 Hz)."""
    floor = HOME[2] - 0.05
    limits = SafetyLimits(workspace_min=[-0.9, -0.9, floor], workspace_max=[0.9, 0.9, 0.9])
    h = harness("descend_until_contact", limits, tick_hz, {"max_travel": 0.15, "speed": 0.05}).script(
        lambda tick, t: NOTHING)
    lowest = HOME[2]
    status = None
    for _ in range(round(20 * tick_hz)):
        status = h.tick()
        lowest = min(lowest, h.arm.pose()[2])
        if status.name != "RUNNING":
            break
    assert status.name == "FAILURE"
    assert floor - 1e-9 <= lowest < floor + 0.05 / tick_hz + 1e-9  # stopped within one period of the floor
    said = h.feedback("main/s")
    assert "workspace box's z min" in said and "no contact" in said, said
    assert h.arm.fault() is None and not h.arm.is_moving()
