"""Randomised scenes (`world: {randomise: true}`): a seed reproduces its draw, another seed draws
another, every draw stays within its documented range, and a cell without the switch is built as
before."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from drivers.cell_builders import CellRequest, load_cell
from drivers.cell_file import CELLS_DIR
from drivers.sim.models.force_sensor import ForceSensorConfig
from drivers.sim.scenes import SCENES, randomise
from perception.sensor_profile import default_profile

SEEDS = range(40)


def nominal(group: str) -> dict[str, float]:
    return {name: 2.0 for name in randomise.GROUPS[group]}


@pytest.mark.parametrize("group", sorted(randomise.GROUPS))
def test_a_seed_draws_the_same_within_range_and_another_seed_another(group):
    draws = [randomise.draw(group, seed, nominal(group)) for seed in SEEDS]
    assert draws[7] == randomise.draw(group, 7, nominal(group))
    for name, r in randomise.GROUPS[group].items():
        values = [d[name] for d in draws]
        assert len(set(values)) == len(values), f"{group}.{name}: two seeds drew the same value"
        low, high = r.bounds(2.0)
        added = 2.0 if name in randomise.ADDED.get(group, ()) else 0.0
        assert all(low + added <= v <= high + added for v in values), f"{group}.{name} left {low}-{high}"
        spread = (max(values) - min(values)) / (high - low)
        assert spread > 0.5, f"{group}.{name}: 40 seeds cover only {spread:.0%} of the range"


def test_instances_draw_apart_and_a_new_parameter_moves_no_other():
    e1, e2 = (randomise.draw("assembly.element", 3, {"mass": 0.4}, instance) for instance in ("E1", "E2"))
    assert e1 != e2
    before = randomise.draw("hold", 3, {"mass": 0.5, "extra_load": 25.0})
    grown = {**randomise.GROUPS, "hold": {**randomise.GROUPS["hold"], "new": randomise.GROUPS["hold"]["mass"]}}
    original = randomise.GROUPS
    try:
        randomise.GROUPS = grown
        after = randomise.draw("hold", 3, {"mass": 0.5, "extra_load": 25.0})
    finally:
        randomise.GROUPS = original
    assert {k: after[k] for k in before} == before


def test_the_sensor_and_the_force_sensor_are_drawn_in_range():
    base = default_profile()
    for seed in SEEDS:
        drawn = randomise.sensor_profile(base, seed)
        ranges = randomise.GROUPS["sensor"]
        assert ranges["gain"].low * 0.85 <= drawn.shear_px_per_n / base.shear_px_per_n <= ranges["gain"].high * 1.15
        assert ranges["skin_lag_s"].low <= drawn.skin_lag_s <= ranges["skin_lag_s"].high
        assert ranges["rest_jitter_px"].low <= drawn.rest_jitter_px <= ranges["rest_jitter_px"].high
        assert drawn == randomise.sensor_profile(base, seed)
        ft = randomise.force_sensor(ForceSensorConfig(), seed)
        assert 0.0 <= ft.offset <= 10.0 and 0.0 <= ft.drift <= 2.0 and 0.2 <= ft.noise <= 1.0
    assert max(randomise.sensor_profile(base, s).skin_lag_s for s in SEEDS) > 0.8  # lags up to 1 s are met


def test_params_leave_a_scene_alone_unless_asked():
    from drivers.sim.scenes.hold import HoldScene

    given = {"mass": 0.5}
    assert randomise.params(HoldScene, "hold", given, {}, 4) == given
    assert randomise.params(HoldScene, "hold", given, {"randomise": False}, 4) == given
    drawn = randomise.params(HoldScene, "hold", given, {"randomise": True}, 4)
    assert drawn != given and set(drawn) == set(given) | set(randomise.GROUPS["hold"])
    assert 0.5 * 0.6 <= drawn["mass"] <= 0.5 * 1.4
    assert 25.0 * 0.6 <= drawn["extra_load"] <= 25.0 * 1.2  # relative to the scene's default


def randomised_cell(tmp_path: Path, on: bool) -> Path:
    text = (CELLS_DIR / "sim.yaml").read_text()
    path = tmp_path / f"sim_{on}.yaml"
    path.write_text(text.replace("\nworld:\n", f"\nworld:\n  randomise: {str(on).lower()}\n", 1))
    return path


ASSEMBLY_ARGS = {"elements": [{"id": "E1", "size": [0.3, 0.04, 0.04], "pick_pose": [0.3, 0.0, 0.02, 0, 0, 0],
                               "plate": "P1"}],
                 "plates": [{"id": "P1", "span": 1.0, "origin": [0.0, 0.4, 0.35]}]}


def test_a_randomised_cell_draws_its_world_per_seed_and_the_skills_keep_the_named_profile(tmp_path):
    cell_file = randomised_cell(tmp_path, True)
    a = load_cell(str(cell_file), 30.0, "assembly", ASSEMBLY_ARGS, seed=1)
    b = load_cell(str(cell_file), 30.0, "assembly", ASSEMBLY_ARGS, seed=2)
    plate_a, plate_b = a.world.plates["P1"], b.world.plates["P1"]
    assert plate_a.beam != plate_b.beam and plate_a.origin != plate_b.origin
    assert a.world.elements["E1"].mass != b.world.elements["E1"].mass
    again = load_cell(str(cell_file), 30.0, "assembly", ASSEMBLY_ARGS, seed=1)
    assert again.world.plates["P1"] == plate_a and again.world.config == a.world.config
    assert a.sensor_profile == default_profile()  # what the lab measured, not the drawn sensor
    for cell in (a, b, again):
        cell.close()


def test_without_the_switch_a_cell_is_built_as_before(tmp_path):
    off = load_cell(str(randomised_cell(tmp_path, False)), 30.0, "assembly", ASSEMBLY_ARGS, seed=1)
    plain = load_cell("sim", 30.0, "assembly", ASSEMBLY_ARGS, seed=1)
    assert off.world.plates["P1"].origin == (0.0, 0.4, 0.35)
    assert off.world.plates == plain.world.plates and off.world.config == plain.world.config
    assert off.sensor_profile == plain.sensor_profile == default_profile()
    off.close()
    plain.close()


@pytest.mark.parametrize("scene", sorted(set(SCENES) - {"assembly"}))
def test_every_scene_builds_randomised_and_steps(scene, tmp_path):
    cell = load_cell(str(randomised_cell(tmp_path, True)), 30.0, scene, {}, seed=5)
    plain = load_cell("sim", 30.0, scene, {}, seed=5)
    for _ in range(5):
        cell.step()
    assert all(np.isfinite(c.normal) for c in cell.world.contacts().values())
    groups = randomise.groups_of(scene)
    assert groups, f"scene {scene} draws nothing of its own"
    drawn, nominal = (getattr(c.world, "handover", c.world) for c in (cell, plain))  # a composite's person
    for name in randomise.GROUPS[groups[0]]:
        assert getattr(drawn, name) != getattr(nominal, name), f"{scene}.{name} was not drawn"
    assert cell.world.grip.friction != plain.world.grip.friction if hasattr(plain.world, "grip") else True
    cell.close()
    plain.close()


def test_every_range_is_documented():
    for group, ranges in randomise.GROUPS.items():
        for name, text in randomise.describe(group).items():
            assert ranges[name].why in text and text.split(":")[0].strip()
    assert dataclasses.is_dataclass(randomise.Range)
    assert CellRequest(30.0).seed == 0


def test_the_handover_press_scale_and_the_followme_closing_axis_cue_are_drawn(tmp_path):
    """The scale under the handed-over stick is drawn as the press scene's (its stiffness and noise reach
    the press part), and the followme fingertips' camera depth and gel stiffness within their ranges."""
    cell_file = str(randomised_cell(tmp_path, True))
    ranges = randomise.GROUPS["handover_press.scale"]
    for seed in (3, 4):
        cell = load_cell(cell_file, 30.0, "handover_press", {}, seed=seed)
        scene = cell.world
        low, high = ranges["contact_stiffness"].bounds(4000.0)
        assert low <= scene.scale["contact_stiffness"] <= high and scene.scale["contact_stiffness"] != 4000.0
        scene.handover.phase = "robot"  # the person let go: the press part begins with the drawn scale
        scene.step(1.0 / 30.0)
        assert scene.press is not None
        assert (scene.press.contact_stiffness, scene.press.scale_noise) == (scene.scale["contact_stiffness"],
                                                                           scene.scale["scale_noise"])
        cell.close()
        follow = load_cell(cell_file, 30.0, "followme", {}, seed=seed)
        assert 0.015 <= follow.world.camera_depth <= 0.03 and 2500.0 <= follow.world.pad_stiffness <= 10000.0
        follow.close()
    plain = load_cell("sim", 30.0, "handover_press", {}, seed=3)
    assert plain.world.scale == {}  # not randomised: the press scene's own scale
    plain.close()
    from assembly.language.catalogue import describe_scenes

    listed = describe_scenes()  # what `fvtree scenes` prints
    assert {"followme.camera_depth", "followme.pad_stiffness"} <= set(listed["followme"]["randomised"])
    assert {"handover_press.scale.contact_stiffness", "handover_press.scale.scale_noise"} <= set(
        listed["handover_press"]["randomised"])
