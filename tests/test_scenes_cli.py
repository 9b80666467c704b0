"""`fvtree scenes`: every simulated scene with what it simulates, its params, its verdict's
tolerances and the demo trees that use it; the schema's `cell.scene` names the same scenes."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest

from assembly.cli import main
from assembly.language.schema import tree_schema
from drivers.sim.scenes import SCENES

TREES = Path(__file__).resolve().parents[1] / "trees"


def test_every_scene_is_listed_with_what_it_simulates_and_its_demo_trees(capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    for name in SCENES:
        assert f"\n{name}: " in f"\n{out}"
    assert "hold: The hold scene: a box stands between the open fingers" in out
    assert "    params: Scene args: mass (kg), extra_load (N), object (wood, glass, rubber, foam, steel;" in out
    assert "(preset='inhand_light')" in out  # a builder made by a factory says how it was made
    assert main(["scenes", "--json"]) == 0
    scenes = json.loads(capsys.readouterr().out)
    assert set(scenes) == set(SCENES)
    assert scenes["press"]["trees"] == ["trees/press_release.yaml", "trees/press_with_force.yaml",
                                        "trees/record_press.yaml"]
    assert scenes["assembly"]["tolerances"] == {"max_regret": 0.01} and scenes["assembly"]["package"] == "fvtree"
    used = {tree for d in scenes.values() for tree in d["trees"]}
    assert used == {f"trees/{p.name}" for p in TREES.glob("*.yaml")}  # each demo tree under its scene


@pytest.mark.parametrize("scene, valid", [("stir", True), ("stirr", False)])
def test_the_schema_names_the_scenes(scene, valid):
    schema = tree_schema()
    assert schema["properties"]["cell"]["properties"]["scene"]["enum"] == sorted(SCENES)
    errors = list(jsonschema.Draft202012Validator(schema).iter_errors({"version": 1, "cell": {"scene": scene}}))
    assert (not errors) == valid
