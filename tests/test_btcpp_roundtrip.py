"""Every shipped tree exported as BehaviorTree.CPP v4 XML is valid against BT.CPP's own XSD, and
imported back it is the same tree: same node paths, kinds, types and params, and the same status
of every node tick by tick on its demo scene."""

from __future__ import annotations

from pathlib import Path

import pytest
import xmlschema

from assembly.interop.btcpp import export_tree, import_xml
from assembly.interop.btcpp.equivalence import differences
from assembly.language.reader import load_tree
from assembly.testing import TreeHarness
from drivers.cell_builders import load_cell

ROOT = Path(__file__).resolve().parents[1]
TREES = sorted(p for p in (ROOT / "trees").glob("*.yaml"))
XSD = xmlschema.XMLSchema(str(Path(__file__).parent / "data" / "btcpp" / "bt4.xsd"))
TICKS = 300  # 10 s of cell time: every demo is well into its skills by then


def round_trip(tree: Path, tmp_path: Path) -> tuple[Path, Path]:
    xml = tmp_path / "out" / f"{tree.stem}.xml"
    xml.parent.mkdir()
    xml.write_text(export_tree(tree, xml.parent))
    back = tmp_path / "back" / f"{tree.stem}.yaml"  # another directory: design and model paths are rebased
    back.parent.mkdir()
    back.write_text(import_xml(xml, back))
    return xml, back


def statuses(doc) -> list[dict[str, str]]:
    cell = load_cell("sim", doc.tick_hz, doc.scene, doc.design.scene_args() if doc.design else {}, seed=3)
    h = TreeHarness.load(doc, cell, None)
    try:
        out = []
        for _ in range(TICKS):
            h.tick()
            out.append({path: node.status.name for path, node in h.tree.nodes.items()})
        return out
    finally:
        h.halt()
        cell.close()


@pytest.mark.parametrize("tree", TREES, ids=[t.stem for t in TREES])
def test_a_shipped_tree_survives_the_round_trip(tree, tmp_path, shipped_designs_allowed):
    xml, back = round_trip(tree, tmp_path)
    XSD.validate(str(xml))
    original, returned = load_tree(tree), load_tree(back)
    assert differences(original, returned) == []
    assert statuses(returned) == statuses(original)


def test_the_nodes_model_lists_every_skill_with_typed_ports(tmp_path, shipped_designs_allowed):
    xml, _ = round_trip(ROOT / "trees" / "assembly.yaml", tmp_path)
    model = XSD.to_dict(str(xml))["TreeNodesModel"]
    actions = {a["@ID"]: a for a in model["Action"]}
    from behaviours.skill_kit.registry import SKILLS

    assert set(SKILLS) <= set(actions)
    ports = {p["@name"]: p for p in actions["gentle_grasp"]["input_port"]}
    assert ports["force"]["@type"] == "double" and "[N]" in ports["force"]["$"]
    assert {d["@ID"] for d in model["Decorator"]} >= {"ForEachElement", "StatusMap"}
