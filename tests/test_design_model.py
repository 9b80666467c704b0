"""The design model holds the design only: simulation data in it is refused with a pointer to the
scene file, and what it hands to the tree and to the simulated scene."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from assembly.design.model import DesignModel
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


SCHEMA_FILE = DESIGN_FILE.parent / "design.schema.json"


def test_the_published_schema_is_current_and_accepts_the_shipped_design():
    jsonschema = pytest.importorskip("jsonschema")
    from assembly.design.model import design_schema

    assert json.loads(SCHEMA_FILE.read_text()) == design_schema(), (
        "regenerate: python -c 'import json; from assembly.design.model import design_schema; "
        "print(json.dumps(design_schema(), indent=1))' > trees/design/design.schema.json")
    jsonschema.Draft202012Validator(design_schema()).validate(json.loads(DESIGN_FILE.read_text()))


@pytest.mark.parametrize("node, field, value, message", [
    (0, "sim_lod", 1, "unknown field 'sim_lod'"),
    (2, "statu", "planned", "unknown field 'statu' (did you mean 'status'?)"),
    (2, "status", "done", "field 'status' must be one of planned, placing, placed"),
    (2, "size", [0.4, 0.04], "field 'size' must be a list of 3 numbers"),
    (2, "size", [0.4, 0.04, 0.0], "field 'size' item 2 must be above 0"),
    (2, "pick_pose", [0, 0, float("nan"), 0, 0, 0], "field 'pick_pose' item 2 must be number (finite)"),
    (0, "span", 0, "field 'span' must be above 0"),
    (0, "origin", "here", "field 'origin' must be array"),
    (2, "kind", [], "kind must be 'element' or 'plate', got []"),  # fuzzing: was a TypeError
    (2, "pick_pose", [0.3, -0.45, 0.02, 1e308, 0, 0], "field 'pick_pose' item 3 must be at most 10"),  # was a math error at run time
])
def test_design_fields_are_checked_by_the_schema_with_the_line(tmp_path, node, field, value, message):
    data = json.loads(DESIGN_FILE.read_text())
    data["nodes"][node][field] = value
    path = tmp_path / "d.json"
    path.write_text(json.dumps(data, indent=1))
    with pytest.raises(TreeError) as err:
        DesignModel.load(path)
    assert message in str(err.value) and err.value.line is not None


def test_a_design_in_memory_is_checked_too():
    graph = DesignModel.load(DESIGN_FILE).graph.copy()
    graph.nodes["E1"]["mass"] = float("inf")
    with pytest.raises(TreeError, match="element 'E1': field 'mass' must be number"):
        DesignModel(graph)
