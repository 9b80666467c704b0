"""press_with_force: presses until the learned force reaches the target (committed demo model),
reports pressing into nothing and unusable models, stops when halted; on the press scene the
scale feels the target."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from assembly.errors import TreeErrors
from assembly.testing import TreeHarness, touch
from drivers.cell_builders import load_cell
from perception.learning.models import load_model

GRIP, WEIGHT = 10.0, 0.05 * 9.81


def one_skill(params: str = "{}") -> TreeHarness:
    return TreeHarness.from_text(f"version: 1\nname: t\nroot: {{skill: press_with_force, name: s, params: {params}}}\n")


def stick_on_scale(h, stiffness: float = 4000.0) -> callable:
    """A stick whose tip meets a surface 2 mm below the start and is pushed back by it."""
    z0 = h.arm.pose()[2] - 0.002

    def script(tick, t):
        force = stiffness * max(0.0, z0 - h.arm.pose()[2]) if stiffness else 0.0
        load_z = WEIGHT - force  # on the hand, along tool z (down at the home pose)
        return {f: touch(f, normal=GRIP, shear=(0.0, load_z / 2), area=0.2) for f in ("left", "right")}
    return script


def test_press_with_force_reaches_the_target_and_holds():
    h = one_skill("{target: 4.0}")
    h.script(stick_on_scale(h))
    assert h.run_until_done(600).name == "SUCCESS"
    assert h.blackboard("/task/press_force") == pytest.approx(4.0, abs=0.3)
    twists = np.array([c.args[0] for c in h.arm.commands_named("speed_linear")])
    assert twists[0][2] == pytest.approx(-0.005)  # full speed down (tool z) while far from the target
    assert abs(twists[-1][2]) < 0.001 and h.arm.commands[-1].name == "stop"  # slowed, then stopped


def test_press_with_force_reports_nothing_under_the_object():
    h = one_skill("{max_travel: 0.02}")
    h.script(stick_on_scale(h, stiffness=0.0))
    assert h.run_until_done(600).name == "FAILURE"
    assert "nothing under the object" in h.feedback("s") and not h.arm.is_moving()


def test_press_with_force_refuses_a_model_of_another_kind_before_it_runs(tmp_path):
    stir = load_model("trees/models/stir_sim.npz", "stir")
    path = stir.save(tmp_path / "stir.npz")
    with pytest.raises(TreeErrors) as err:
        one_skill(f"{{model: {path}}}")
    assert "a 'force' model is needed" in str(err.value)


def test_press_with_force_halted_stops_the_arm():
    h = one_skill()
    h.script(stick_on_scale(h))
    h.tick(10)
    assert h.arm.is_moving()
    h.halt()
    assert not h.arm.is_moving()


@pytest.mark.parametrize("target", [2.0, 8.0])
def test_the_scale_feels_the_target(target):
    cell = load_cell("sim", 30, "press", {})
    text = Path("trees/press_with_force.yaml").read_text().replace("target: 5.0", f"target: {target}")
    harness = TreeHarness.from_text(text, cell=cell, name="trees/press_with_force.yaml")
    assert harness.run_until_done(2000).name == "SUCCESS"
    assert cell.world.force == pytest.approx(target, abs=0.3)
