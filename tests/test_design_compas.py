"""The design model as COMPAS data: both directions, round-trip against the node-link file,
opened by `compas.json_load` alone, and refused with a located error when it is not ours."""

from __future__ import annotations

import json
from pathlib import Path

import compas
import numpy as np
import pytest
from compas.datastructures import Graph
from compas.geometry import Box, Frame
from scipy.spatial.transform import Rotation

from assembly.cli import main
from assembly.design.link import compas_data
from assembly.design.model import DesignModel
from assembly.errors import TreeError

DESIGNS = Path(__file__).resolve().parents[1] / "trees" / "design"


def canonical(data: dict) -> dict:
    """Node-link data with nodes and edges sorted, for comparing two documents."""
    return {**data, "nodes": sorted(data["nodes"], key=lambda n: n["id"]),
            "edges": sorted(data["edges"], key=lambda e: (e["source"], e["target"]))}


def as_built() -> DesignModel:
    """six_bays with one element placed (as-built pose, load, cell), one placing, one planned pose."""
    model = DesignModel.load(DESIGNS / "six_bays.json")
    model.graph.nodes["E1"].update(status="placed", asbuilt_pose=[0.011, 0.4, 0.2375, 0.0, -1.5707963, 0.0],
                                   measured_load=27.39, cell="A")
    model.graph.nodes["E2"].update(status="placing", asbuilt_pose=[-0.45, -0.35, 0.2375, 0.1, 0.2, -0.3],
                                   measured_load=None)
    model.graph.nodes["E3"]["planned_pose"] = [-0.3, 0.62, 0.2375, 2.9, 0.1, -0.4]
    return model


@pytest.mark.parametrize("name", ["two_bays.json", "three_bays.json", "six_bays.json"])
def test_every_shipped_design_goes_to_compas_and_back_unchanged(name, tmp_path):
    model = DesignModel.load(DESIGNS / name)
    path = compas_data.save_compas(model, tmp_path / "design.compas.json")
    assert canonical(compas_data.load_compas(path).to_data()) == canonical(model.to_data())


def test_an_as_built_model_round_trips_with_frames_loads_and_cells(tmp_path):
    model = as_built()
    back = compas_data.load_compas(compas_data.save_compas(model, tmp_path / "asbuilt.compas.json"))
    want, got = canonical(model.to_data()), canonical(back.to_data())
    for a, b in zip(want["nodes"], got["nodes"]):
        assert a.keys() == b.keys(), a["id"]
        for key in a:
            if key.endswith("_pose") and a[key] is not None:
                np.testing.assert_allclose(b[key], a[key], atol=1e-8, err_msg=f"{a['id']}.{key}")
            else:
                assert b[key] == a[key], f"{a['id']}.{key}"
    assert got["edges"] == want["edges"]


def test_compas_alone_opens_the_file_as_a_graph_with_frames_and_boxes(tmp_path):
    path = compas_data.save_compas(as_built(), tmp_path / "asbuilt.compas.json")
    graph = compas.json_load(str(path))  # what a COMPAS user does, without this package
    assert isinstance(graph, Graph) and graph.attributes["units"] == "m"
    e1 = graph.node_attributes("E1")
    assert isinstance(e1["asbuilt_frame"], Frame) and isinstance(e1["box"], Box)
    assert e1["status"] == "placed" and e1["measured_load"] == 27.39 and e1["cell"] == "A"
    # the display box stands where the element was built, its length along the frame's x axis
    assert np.allclose(list(e1["box"].frame.point), [0.011, 0.4, 0.2375])
    assert e1["box"].xsize == pytest.approx(0.435)
    assert np.allclose(list(e1["asbuilt_frame"].xaxis), [0, 0, 1], atol=1e-6)  # upright: length along z
    assert ("E1", "E3") in set(graph.edges())  # direction kept: E1 before E3
    plate = graph.node_attributes("P1")
    assert list(plate["frame"].point) == [-0.55, 0.30, 0.46] and plate["span"] == 1.0


@pytest.mark.parametrize("pose", [[0.1, -0.2, 0.3, 0.0, 0.0, 0.0], [0.5, 0.5, 0.1, 3.0, 0.0, 0.0],
                                  [0.0, 0.0, 0.5, 3.141593, 0.0, 0.0], [1.0, 2.0, 3.0, -0.4, 1.1, 0.7]])
def test_a_pose_and_its_frame_are_the_same_rotation(pose):
    back = compas_data.frame_to_pose(compas_data.pose_to_frame(pose))
    np.testing.assert_allclose(back[:3], pose[:3])
    assert np.allclose(Rotation.from_rotvec(back[3:]).as_matrix(), Rotation.from_rotvec(pose[3:]).as_matrix())


def test_a_live_plan_reads_back_with_its_passing_states_as_planned():
    graph = compas_data.to_graph(DesignModel.load(DESIGNS / "two_bays.json"))
    graph.node_attribute("E1", "status", "picking")  # what a cell's live plan shows
    graph.node_attribute("E2", "status", "failed")
    model = compas_data.from_graph(graph)
    assert [model.graph.nodes[e]["status"] for e in ("E1", "E2")] == ["planned", "planned"]


def test_a_graph_not_written_by_fvtree_is_refused_with_the_file(tmp_path):
    path = tmp_path / "other.json"
    compas.json_dump(Graph(), str(path))
    with pytest.raises(TreeError, match="format") as err:
        compas_data.load_compas(path)
    assert err.value.file == str(path)
    graph = compas_data.to_graph(DesignModel.load(DESIGNS / "two_bays.json"))
    graph.node_attribute("E1", "plate", "P9")
    with pytest.raises(TreeError, match="props plate 'P9'"):
        compas_data.from_graph(graph)
    (tmp_path / "broken.json").write_text("{not json")
    with pytest.raises(TreeError, match="not COMPAS JSON"):
        compas_data.load_compas(tmp_path / "broken.json")


def test_fvtree_design_converts_both_ways(tmp_path, capsys):
    assert main(["design", "to-compas", str(DESIGNS / "two_bays.json"), str(tmp_path / "c.json")]) == 0
    assert main(["design", "from-compas", str(tmp_path / "c.json"), str(tmp_path / "n.json")]) == 0
    assert canonical(json.loads((tmp_path / "n.json").read_text())) == canonical(
        DesignModel.load(DESIGNS / "two_bays.json").to_data())
    assert main(["validate", str(tmp_path / "n.json")]) == 0
