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


AUTOREMAP = """\
<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence name="top">
      <SubTree ID="Lift" name="up" _autoremap="true"/>
      <SubTree ID="Lift" name="up_slowly" _autoremap="true" speed="0.01"/>
      <SubTree ID="Carry" name="carry" _autoremap="true"/>
      <SubTree ID="Carry" name="carry_given" _autoremap="false" pace="0.3"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Lift">
    <move_to name="lift" offset="0;0;0.05" speed="{speed}"/>
  </BehaviorTree>
  <BehaviorTree ID="Carry">
    <Sequence name="carry_body">
      <SubTree ID="Lift" name="inner" _autoremap="true"/>
      <move_to name="over" offset="0;0;0.1" speed="{pace}"/>
    </Sequence>
  </BehaviorTree>
  <TreeNodesModel>
    <SubTree ID="Main" editable="true"><input_port name="speed" default="0.2"/></SubTree>
    <SubTree ID="Lift" editable="true"><input_port name="speed" default="0.1"/></SubTree>
    <SubTree ID="Carry" editable="true">
      <input_port name="speed" type="double" default="0.05"/><input_port name="pace" type="double"/>
    </SubTree>
  </TreeNodesModel>
</root>
"""


def walk(spec):
    yield spec
    for child in spec.children:
        yield from walk(child)


def test_autoremap_passes_the_namesakes_of_the_enclosing_tree(tmp_path):
    xml = tmp_path / "autoremap.xml"
    xml.write_text(AUTOREMAP.replace('name="carry" _autoremap="true"/>', 'name="carry" _autoremap="true" pace="0.2"/>'))
    text = import_xml(xml, tmp_path / "autoremap.yaml")  # validated on the way
    doc = yaml.safe_load(text)
    up, up_slowly, carry, carry_given = doc["root"]["children"]
    assert up["params"] == {"speed": 0.2}  # the main tree's port `speed`, as BT.CPP's parent blackboard
    assert up_slowly["params"] == {"speed": 0.01}  # given: kept
    assert carry["params"] == {"speed": 0.2, "pace": 0.2}
    assert carry_given["params"] == {"pace": 0.3}  # no autoremap: Carry's own default speed
    inner = doc["subtrees"]["Carry"]["root"]["children"][0]
    assert inner == {"subtree": "Lift", "name": "inner", "params": {"speed": "$speed"}}  # Carry's param
    (tmp_path / "autoremap.yaml").write_text(text)
    nodes = {spec.path: spec for spec in walk(load_tree(tmp_path / "autoremap.yaml").root)}
    assert nodes["top/up/lift"].args["params"]["speed"] == 0.2  # what BT.CPP's blackboard would hold
    assert nodes["top/carry_given/carry_body/inner/lift"].args["params"]["speed"] == 0.05


def test_autoremap_with_nothing_to_remap_a_required_param_to_is_refused(tmp_path):
    xml = tmp_path / "autoremap.xml"
    xml.write_text(AUTOREMAP.replace('_autoremap="false" pace="0.3"', '_autoremap="{flag}" pace="0.3"'))
    with pytest.raises(TreeErrors) as caught:
        import_xml(xml, tmp_path / "autoremap.yaml")
    errors = [(e.line, e.message) for e in caught.value.errors]
    line = AUTOREMAP.splitlines().index('      <SubTree ID="Carry" name="carry" _autoremap="true"/>') + 1
    missing = "_autoremap: the subtree's param 'pace' has no default, and no port of the main tree is named 'pace'"
    assert (line, missing + " to remap it to") in errors
    assert (line + 1, "_autoremap: expected true or false, got '{flag}'") in errors


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


def test_a_file_exported_with_the_old_processing_instruction_still_imports(tmp_path):
    tree = ROOT / "trees" / "assembly.yaml"
    text = export_tree(tree, tmp_path)
    start, end = text.index("<!-- fvtree "), text.index("-->")
    old = text[:start] + "<?fvtree " + text[start + len("<!-- fvtree "):end].strip() + "?>" + text[end + 3:]
    (tmp_path / "old.xml").write_text(old)
    back = tmp_path / "old.yaml"
    back.write_text(import_xml(tmp_path / "old.xml", back))
    assert differences(load_tree(tree), load_tree(back)) == []
    assert "descend_speed" not in back.read_text().split("subtrees:")[0]  # the written-out defaults left out again
