"""Importing BT.CPP XML as a Groot2 user writes it: `{key}` ports mapped where fvtree has an
equivalent (a subtree param, a port the main tree declares with a default, a project blackboard
key where a condition reads one) and refused with their XML line otherwise; every refusal of a file
reported at once; and what validation finds in the result said of the XML line, not of YAML."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from assembly.cli import main
from assembly.errors import TreeErrors
from assembly.interop.btcpp import export_tree, import_xml
from assembly.interop.btcpp.equivalence import differences
from assembly.language.reader import load_tree

ROOT = Path(__file__).resolve().parents[1]

GROOT2 = """\
<?xml version="1.0" encoding="UTF-8"?>
<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence name="top">
      <SubTree ID="Lift" speed="{lift_speed}"/>
      <BlackboardCheck name="slip" key="{fv_left__slip}" op="gt" value="0.5"/>
      <move_to name="back" pose="" offset="0;0;-0.05" speed="{speed}"/>
      <ScriptCondition name="light" code="@fv_left__slip &lt; limit"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Lift">
    <move_to offset="0;0;0.05" speed="{speed}"/>
  </BehaviorTree>
  <TreeNodesModel>
    <SubTree ID="Main" editable="true">
      <input_port name="speed" default="0.2"/>
      <input_port name="limit" default="0.4"/>
      <input_port name="lift_speed" default="0.07"/>
    </SubTree>
    <SubTree ID="Lift" editable="true">
      <input_port name="speed" default="0.1"/>
    </SubTree>
  </TreeNodesModel>
</root>
"""


def test_key_ports_with_an_equivalent_are_mapped(tmp_path):
    xml = tmp_path / "groot.xml"
    xml.write_text(GROOT2)
    doc = yaml.safe_load(import_xml(xml, tmp_path / "groot.yaml"))
    lift, slip, back, light = doc["root"]["children"]
    assert lift == {"subtree": "Lift", "params": {"speed": 0.07}}  # the main tree's port default
    assert doc["subtrees"]["Lift"]["root"]["params"]["speed"] == "$speed"  # the subtree's own param
    assert slip["key"] == "/fv/left.slip"  # the project's key its script spelling names
    assert back["params"] == {"offset": [0, 0, -0.05], "speed": 0.2}  # pose="" is a param left out
    assert (light["key"], light["op"], light["value"]) == ("/fv/left.slip", "lt", 0.4)


BAD = """\
<?xml version="1.0" encoding="UTF-8"?>
<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <SequenceWithMemory name="top">
      <move_to name="home" pose="{home}"/>
      <move_to name="there" pose="{task_element}"/>
      <Sleep msec="10"/>
      <Inverter>
        <move_to name="deep" offset="0;0;1" speed="{fast}"/>
      </Inverter>
    </SequenceWithMemory>
  </BehaviorTree>
  <BehaviorTree ID="Lift">
    <move_to offset="0;0;0.05" pose="{pose}"/>
  </BehaviorTree>
</root>
"""


def test_every_refusal_of_a_file_is_reported_at_once_with_its_xml_line(tmp_path, capsys):
    xml = tmp_path / "bad.xml"
    xml.write_text(BAD)
    with pytest.raises(TreeErrors) as err:
        import_xml(xml, tmp_path / "bad.yaml")
    found = [(e.line, e.message) for e in err.value.errors]
    assert [line for line, _ in found] == [4, 5, 6, 7, 9, 14]
    assert "SequenceWithMemory> has no equivalent" in found[0][1]  # the root refused hides nothing below it
    assert "{home} is not a port of the main tree" in found[1][1]
    assert "{task_element}" in found[2][1] and "/task/element is read by the skills" in str(err.value)
    assert "Sleep" in found[3][1] and "{fast}" in found[4][1] and "{pose} is not a param of this subtree" in found[5][1]
    assert all(e.file == str(xml) for e in err.value.errors)
    assert main(["import", str(xml), "-o", str(tmp_path / "bad.yaml")]) == 2
    assert capsys.readouterr().err.count("bad.xml:") == 6


def test_what_validation_finds_is_said_of_the_xml_line(tmp_path):
    xml = tmp_path / "v.xml"
    xml.write_text('<root BTCPP_format="4" main_tree_to_execute="M">\n<BehaviorTree ID="M">\n<Sequence>\n'
                   '<move_to offset="0;0;0.1"/>\n<Inverter>\n<move_to offset="0;0;0.1" speed="-5"/>\n</Inverter>\n'
                   '<move_to name="nowhere" speed="0.2"/>\n</Sequence>\n</BehaviorTree>\n</root>\n')
    with pytest.raises(TreeErrors) as err:
        import_xml(xml, tmp_path / "v.yaml")
    text = str(err.value)
    assert "v.yaml" not in text
    assert "v.xml:6: Sequence/Inverter/move_to: param 'speed'" in text
    assert "v.xml:8: Sequence/nowhere: give exactly one of 'pose' or 'offset'" in text


def test_a_file_exported_with_the_old_processing_instruction_still_imports(tmp_path, shipped_designs_allowed):
    tree = ROOT / "trees" / "assembly.yaml"
    text = export_tree(tree, tmp_path)
    start, end = text.index("<!-- fvtree "), text.index("-->")
    old = text[:start] + "<?fvtree " + text[start + len("<!-- fvtree "):end].strip() + "?>" + text[end + 3:]
    (tmp_path / "old.xml").write_text(old)
    back = tmp_path / "old.yaml"
    back.write_text(import_xml(tmp_path / "old.xml", back))
    assert differences(load_tree(tree), load_tree(back)) == []
    assert "descend_speed" not in back.read_text().split("subtrees:")[0]  # the written-out defaults left out again
