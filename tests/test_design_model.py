"""The design model holds the design only: simulation data in it is refused with a pointer to the
scene file, and what it hands to the tree and to the simulated scene."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from assembly.design import DesignModel
from assembly.errors import TreeError

DESIGN_FILE = Path(__file__).resolve().parents[1] / "trees" / "design" / "two_bays.json"


def test_a_plate_with_simulated_loads_is_refused_with_a_pointer_to_the_scene_file(tmp_path):
    data = json.loads(DESIGN_FILE.read_text())
    data["nodes"][0]["sim_load"] = {"EI": 50.0}
    path = tmp_path / "bays.json"
    path.write_text(json.dumps(data))
    with pytest.raises(TreeError) as err:
        DesignModel.load(path)
    assert err.value.file == str(path) and "'sim_load' is simulation data" in err.value.message
    assert "bays.scene.yaml" in err.value.hint and "P1" in err.value.hint


def test_the_plates_the_tree_sees_are_geometry_only():
    design = DesignModel.load(DESIGN_FILE)
    for plate in design.plates().values():
        assert set(plate) == {"kind", "origin", "span", "width"}


def test_scene_args_name_the_design_file_the_scene_reads_its_own_file_next_to():
    args = DesignModel.load(DESIGN_FILE).scene_args()
    assert args["design_file"] == str(DESIGN_FILE)
    assert [e["id"] for e in args["elements"]] == ["E1", "E2"] and [p["id"] for p in args["plates"]] == ["P1", "P2"]
    graph = DesignModel.load(DESIGN_FILE).graph
    assert DesignModel(graph).scene_args()["design_file"] is None  # a design in memory has no scene file
