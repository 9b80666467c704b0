"""stir: follows the predefined movement with velocity commands, marks the trial for the
recorder, cycles through the movements, reports an arm fault, stops when halted."""

from __future__ import annotations

import numpy as np
import pytest

from assembly.testing import TreeHarness
from behaviours.skill_kit.stirring import MOVEMENTS
from perception.learning.features import REST_TICKS


def one_skill(params: str = "{}", times: int = 1) -> TreeHarness:
    node = f"{{skill: stir, name: s, params: {params}}}"
    root = node if times == 1 else f"{{repeat: r, times: {times}, child: {node}}}"
    return TreeHarness.from_text(f"version: 1\nname: t\nroot: {root}\n")


def test_stir_follows_the_movement_and_comes_back():
    h = one_skill("{movement: circle_large_slow, duration: 3.0}")
    start = h.arm.pose()
    h.tick(REST_TICKS)  # held still first: the trial's rest rows, StirLearn's reference
    assert not h.arm.is_moving() and h.blackboard("/task/stir_trial")["active"] is True
    assert np.allclose(h.arm.pose(), start)
    path = []
    for _ in range(90):
        h.tick()
        path.append(h.arm.pose()[:2] - start[:2])
        assert h.blackboard("/task/stir_trial") == {"trial": 0, "movement": "circle_large_slow", "active": True}
    expected = np.array([MOVEMENTS["circle_large_slow"]((i + 1) / 30) for i in range(90)])
    assert np.abs(np.array(path) - expected).max() < 1e-6  # on the circle, tick by tick
    assert h.run_until_done(200).name == "SUCCESS"
    assert np.allclose(h.arm.pose(), start) and h.blackboard("/task/stir_trial")["active"] is False


def test_stir_cycles_through_the_movements():
    h = one_skill("{duration: 0.5}", times=3)
    seen = set()
    while h.tick().name == "RUNNING":
        seen.add(h.blackboard("/task/stir_trial")["movement"])
    assert seen == set(list(MOVEMENTS)[:3]) and h.blackboard("/task/stir_trial")["trial"] == 2


def test_stir_reports_an_arm_fault():
    h = one_skill("{duration: 0.5}")
    h.tick(20)
    h.arm.trip("protective stop")
    assert h.run_until_done(100).name == "FAILURE"
    assert "protective stop" in h.feedback("s")


def test_stir_halted_stops_the_arm():
    h = one_skill()
    h.tick(REST_TICKS + 10)
    assert h.arm.is_moving()
    h.halt()
    assert h.status("s") == "INVALID" and not h.arm.is_moving()


def test_stir_rejects_an_unknown_movement():
    with pytest.raises(Exception, match="not one of"):
        one_skill("{movement: whisk}")
