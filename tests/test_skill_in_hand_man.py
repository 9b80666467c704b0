"""in_hand_man: the original step-open / step-close pivot, its failures, halting, and the bar
scene."""

from __future__ import annotations

import math

import numpy as np
import pytest

from assembly.testing import TreeHarness, mock_cell, touch
from drivers.cell_builders import load_cell

W0 = 0.015


def one_skill(params: str = "{}") -> TreeHarness:
    text = f"version: 1\nname: t\nroot: {{skill: in_hand_man, name: s, params: {params}}}\n"
    return TreeHarness.from_text(text, cell=mock_cell(gripper_width=W0, object_width=0.02))


def bar(h, turned: list) -> dict:
    """A bar that turns 1 deg per tick, slipping, while the fingers are open beyond 1 mm."""
    if h.gripper.width() > W0 + 0.001:
        turned[0] += 1.0
    slip = 0.06 if h.gripper.width() > W0 + 0.001 else 0.0
    return {f: touch(f, normal=10.0, area=0.25, orientation=s * math.radians(turned[0]), slip=slip)
            for f, s in (("left", -1.0), ("right", 1.0))}


def test_in_hand_man_opens_by_steps_until_slip_closes_while_slipping():
    h = one_skill("{target: 20, step: 0.0005}")
    turned = [0.0]
    h.script(lambda tick, t: bar(h, turned))
    assert h.run_until_done(300).name == "SUCCESS"
    w = np.array([c.args[0] for c in h.gripper.commands_named("move")])
    steps = np.round(np.diff(w) * 1e4) / 1e4
    assert set(steps) <= {0.0005, -0.0005} and (steps < 0).any() and (steps > 0).any()
    assert h.blackboard("/task/object_angle") > 20.0


def test_in_hand_man_reports_an_object_that_never_turns():
    h = one_skill("{opening: 0.003}")
    h.script(lambda tick, t: {f: touch(f, normal=10.0, area=0.25) for f in ("left", "right")})
    assert h.run_until_done(100).name == "FAILURE"
    assert "did not turn" in h.feedback("s")


def test_in_hand_man_halted_stops_the_gripper():
    h = one_skill()
    turned = [0.0]
    h.script(lambda tick, t: bar(h, turned))
    h.tick(3)
    h.halt()
    assert h.status("s") == "INVALID" and h.gripper.commands[-1].name == "stop"


def test_in_hand_man_pivots_the_bar_in_the_scene():
    cell = load_cell("sim", 30, "inhand", {})
    assert TreeHarness.from_file("trees/in_hand_man.yaml", cell=cell).run_until_done(1000).name == "SUCCESS"
    m = cell.world.metrics()
    assert m["turned in the hand (deg)"] == pytest.approx(21.0, abs=3.0) and not m["stick dropped"]


def test_in_hand_man_needs_slip_felt_to_succeed():
    """The view turns 1 deg per tick but the pads never feel slip: not a pivot in the fingers."""
    h = one_skill("{target: 10}")
    turned = [0.0]

    def script(tick, t):
        turned[0] += 1.0
        return {f: touch(f, normal=10.0, area=0.25, orientation=s * math.radians(turned[0]))
                for f, s in (("left", -1.0), ("right", 1.0))}
    h.script(script)
    assert h.run_until_done(100).name == "FAILURE"
    assert "no slip was felt" in h.feedback("s") and h.blackboard("/task/object_angle") is None
