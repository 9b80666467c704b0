"""BehaviorTree.CPP v4 XML: every node kind exported and read back, files as Groot2 writes them,
and what has no equivalent refused with the XML line and the reason (exit code 2)."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
import xmlschema

from assembly.cli import main
from assembly.errors import TreeErrors
from assembly.interop.btcpp import export_tree, import_xml
from assembly.interop.btcpp.equivalence import differences, outline
from assembly.language.reader import load_tree
from assembly.testing import TreeHarness, mock_cell, touch
from fvfiles.errors import FvtreeError

XSD = xmlschema.XMLSchema(str(Path(__file__).parent / "data" / "btcpp" / "bt4.xsd"))

# Every node kind, each spelling of the kinds with several (memory, parallel policies, status maps).
ALL_KINDS = """\
version: 1
name: all_kinds
cell: {tick_hz: 30, scene: hold}
subtrees:
  checked_grasp:
    params: {limit: {type: float, default: 2.0, unit: N}, tries: int}
    root:
      retry: tries
      attempts: $tries
      child:
        sequence: grasp_and_check
        memory: true
        children:
          - {skill: gentle_grasp, name: grasp, params: {force: 30.0, squeeze: 0.002}}
          - {condition: light, key: "/fv/left.force[2]", op: lt, value: $limit}
root:
  selector: top
  memory: false
  children:
    - {condition: label, key: /fv/left.health_reason, op: eq, value: peas}
    - {condition: stopped, key: /task/estop, op: eq, value: true}
    - {condition: built, key: /task/asbuilt, op: exists}
    - sequence: work
      memory: true
      children:
        - {subtree: checked_grasp, name: grab, params: {tries: 2}}
        - status_map: optional
          map: {failure: success}
          child: {condition: slipping, key: /fv/left.slip, op: gt, value: 0.5}
        - status_map: keep_going
          map: {failure: success, running: running}
          child: {skill: move_to, name: nudge, params: {offset: [0.0, 0.0, 0.01]}}
        - inverter: not_slipping
          child: {condition: slip, key: /fv/right.slip, op: ge, value: 0.5}
        - parallel: both
          policy: all
          synchronise: true
          children:
            - repeat: twice
              times: 2
              child: {condition: holding, key: /gripper/object, op: eq, value: true}
            - timeout: quick
              seconds: 2.5
              child:
                guard: while_light
                while: {key: "/fv/left.force[2]", op: le, value: 10.0}
                child: {skill: move_to, name: up, params: {offset: [0.0, 0.0, 0.05]}}
        - sequence: watch
          memory: false
          children:
            - {condition: still_holding, key: /gripper/object, op: eq, value: true}
            - parallel: any
              policy: one
              children:
                - {skill: move_to, name: a, params: {offset: [0.01, 0.0, 0.0]}}
                - {condition: b, key: /gripper/width, op: gt, value: 0.05}
        - parallel: chosen
          policy: selected
          selected: [c]
          children:
            - {skill: move_to, name: c, params: {offset: [0.01, 0.0, 0.0]}}
            - {condition: d, key: "/robot/pose[-1]", op: ne, value: 0.0}
"""


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_every_node_kind_round_trips_and_the_xml_is_valid(tmp_path):
    tree = write(tmp_path, "all.yaml", ALL_KINDS)
    xml = write(tmp_path, "all.xml", export_tree(tree, tmp_path))
    XSD.validate(str(xml))
    text = xml.read_text()
    for spelling in ('<ReactiveFallback name="top">', '<ReactiveSequence name="watch">', '<Sequence name="grasp_and_',
                     '<ForceSuccess name="optional">', 'map="failure:success;running:running"',
                     '<Parallel name="both" success_count="-1" failure_count="1">', 'name="any" success_count="1"',
                     '<FvParallel name="chosen" policy="selected" synchronise="false" selected="c">',
                     '<ReactiveSequence name="while_light">',
                     '<ScriptCondition name="while_light.while" code="@fv_left__force__2 &lt;= 10.0" />',
                     'code="@fv_left__force__2 &lt; limit"', 'num_attempts="{tries}"', '<Timeout name="quick" msec="2500">',
                     '<BlackboardCheck name="built" key="/task/asbuilt" op="exists" />',
                     'code="@robot_pose__m1 != 0.0"', 'code="@fv_left__health_reason == \'peas\'"'):
        assert spelling in text
    back = write(tmp_path, "back.yaml", import_xml(xml, tmp_path / "back.yaml"))
    original, returned = load_tree(tree, dataflow=False), load_tree(back, dataflow=False)
    assert differences(original, returned) == []

    def ticks(doc) -> list[dict]:
        h = TreeHarness.load(doc, mock_cell(30, gripper_width=0.06, object_width=0.04), None)
        h.script(lambda tick, t: {f: touch(f, normal=max(0.0, (0.04 - h.gripper.width()) * 5000), slip=0.6 * (tick > 150))
                                  for f in ("left", "right")})  # a 40 mm object, slipping after 5 s
        seen = []
        for _ in range(240):
            h.tick()
            seen.append({p: n.status.name for p, n in h.tree.nodes.items()})
        return seen

    assert ticks(returned) == ticks(original)


GROOT2 = """\
<?xml version="1.0" encoding="UTF-8"?>
<root BTCPP_format="4" main_tree_to_execute="MainTree">
  <BehaviorTree ID="MainTree" _fullpath="">
    <Sequence _uid="1">
      <gentle_grasp name="grasp" force="30" squeeze="0.002" _uid="2"/>
      <SubTree ID="Lift" speed="0.05" _uid="3"/>
      <Sequence _uid="4">
        <move_to name="back" offset="0;0;-0.05" _while="@fv_left__slip &lt; 0.5" _description="down again"/>
      </Sequence>
      <Sequence _uid="5"><move_to offset="0;0;0.01"/></Sequence>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Lift">
    <move_to offset="0;0;0.05" speed="{speed}"/>
  </BehaviorTree>
  <!-- Description of Node Models (used by Groot) -->
  <TreeNodesModel>
    <SubTree ID="Lift" editable="true">
      <input_port name="speed" default="0.1"/>
    </SubTree>
    <Action ID="gentle_grasp" editable="true">
      <input_port name="force"/>
    </Action>
  </TreeNodesModel>
</root>
"""


def test_a_groot2_file_with_its_layout_metadata_imports_into_a_valid_tree(tmp_path):
    xml = write(tmp_path, "groot.xml", GROOT2)
    text = import_xml(xml, tmp_path / "groot.yaml")
    doc = load_tree(write(tmp_path, "groot.yaml", text))
    paths = [p for p in TreeHarness.load(doc, None, None).tree.nodes]
    assert {"Sequence/Sequence/back_while/back", "Sequence/Sequence_2/move_to", "Sequence/Lift/move_to"} <= set(paths)
    assert "doc: down again" in text and "$speed" in text
    assert doc.subtrees["Lift"].params["speed"].type == "float"  # typed by the skill param it feeds
    assert doc.subtrees["Lift"].params["speed"].default == 0.1


@pytest.mark.parametrize("node, line, reason", [
    ('<SequenceWithMemory name="s"><move_to offset="0;0;0.1"/></SequenceWithMemory>', 3, "resumes at the failed"),
    ('<move_to offset="0;0;0.1" _skipIf="@task_estop == true"/>', 3, "SKIPPED"),
    ('<Sleep msec="100"/>', 3, "wall clock"),
    ('<Sequence>\n<fly_to/>\n</Sequence>', 4, "neither a BT.CPP node"),
    ('<move_to offset="north"/>', 3, "expected a number"),
    ('<move_to ofset="0;0;1"/>', 3, "did you mean 'offset'"),
    ('<ScriptCondition code="@task_estop := true"/>', 3, "only comparisons"),
    ('<Parallel success_count="2"><move_to offset="0;0;1"/></Parallel>', 3, "success_count=2"),
])
def test_what_has_no_equivalent_is_refused_with_its_line(tmp_path, capsys, node, line, reason):
    xml = write(tmp_path, "bad.xml", f'<?xml version="1.0"?>\n<root BTCPP_format="4">\n'
                                     f'<BehaviorTree ID="t">{node}</BehaviorTree>\n</root>\n')
    with pytest.raises(TreeErrors) as err:
        import_xml(xml, tmp_path / "bad.yaml")
    assert f"bad.xml:{line}:" in str(err.value) and reason in str(err.value)
    assert main(["import", str(xml), "-o", str(tmp_path / "bad.yaml")]) == 2
    assert reason in capsys.readouterr().err and not (tmp_path / "bad.yaml").exists()


@pytest.mark.parametrize("text, message", [
    ('<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;">]>\n<root BTCPP_format="4"/>',
     "DOCTYPE"),
    ('<?xml version="1.0"?>\n<!DOCTYPE r SYSTEM "file:///etc/passwd">\n<root BTCPP_format="4"/>', "DOCTYPE"),
    ('<root BTCPP_format="4">\n<BehaviorTree ID="t">\n</root>', "not well-formed"),
    ('<root BTCPP_format="3"><BehaviorTree ID="t"><move_to/></BehaviorTree></root>', "v4"),
    ("<root BTCPP_format='4'>" + "<Inverter>" * 300 + "</Inverter>" * 300 + "</root>", "nested deeper"),
])
def test_unsafe_or_foreign_xml_is_refused(tmp_path, text, message):
    with pytest.raises(FvtreeError, match=message):
        import_xml(write(tmp_path, "x.xml", text), tmp_path / "x.yaml")


def test_what_bt_cpp_cannot_say_is_refused_at_export(tmp_path, capsys):
    tree = write(tmp_path, "t.yaml", """\
        version: 1
        name: t
        root:
          timeout: short
          seconds: 0.0005
          child: {skill: move_to, params: {offset: [0.0, 0.0, 0.1]}}
        """)
    assert main(["export", str(tree), "-o", str(tmp_path / "t.xml")]) == 2
    err = capsys.readouterr().err
    assert "t.yaml:4: short: cannot export" in err and "msec" in err


def test_an_empty_element_list_is_refused_at_export(tmp_path, capsys, shipped_designs_allowed):
    """An empty port is a param left out (BT.CPP's generated XSD needs that default), so
    `elements: []` has no spelling of its own."""
    design = Path(__file__).resolve().parents[1] / "trees" / "design" / "two_bays.json"
    tree = write(tmp_path, "t.yaml", f"""\
        version: 1
        name: t
        design: {design}
        root:
          for_each_element: each
          elements: []
          child: {{skill: move_to, params: {{offset: [0.0, 0.0, 0.1]}}}}
        """)
    assert main(["export", str(tree), "-o", str(tmp_path / "t.xml")]) == 2
    assert "t.yaml:5: each: cannot export: 'elements: []'" in capsys.readouterr().err


def test_export_and_import_on_the_command_line(tmp_path, capsys, shipped_designs_allowed):
    root = Path(__file__).resolve().parents[1]
    xml, back = tmp_path / "a.xml", tmp_path / "sub" / "a.yaml"
    back.parent.mkdir()
    assert main(["export", str(root / "trees" / "assembly.yaml"), "--format", "btcpp", "-o", str(xml)]) == 0
    assert main(["import", str(xml), "-o", str(back)]) == 0
    assert differences(load_tree(root / "trees" / "assembly.yaml"), load_tree(back)) == []
    assert "design: ../" in back.read_text()


def test_subtree_ports_declared_the_groot2_way_type_a_file_without_our_metadata(tmp_path, capsys):
    root = Path(__file__).resolve().parents[1]
    tree = root / "trees" / "classify_substance.yaml"
    xml = tmp_path / "c.xml"
    assert main(["export", str(tree), "--subtree-models", "-o", str(xml)]) == 0
    text = xml.read_text()
    assert '<SubTree ID="classify_bowl" editable="true">' in text and 'type="std::vector&lt;double&gt;"' in text
    start = text.index("<!-- fvtree")
    xml.write_text(text[:start] + text[text.index("-->", start) + 3:])  # as Groot2 would save it: no metadata
    back = write(tmp_path, "c.yaml", import_xml(xml, tmp_path / "c.yaml"))
    original, returned = load_tree(tree), load_tree(back)
    assert returned.subtrees["classify_bowl"].params["at"].type == "vector"
    assert outline(returned) == outline(original)  # the cell settings went with the metadata; the nodes did not


def test_a_guard_a_script_cannot_say_is_a_reactive_sequence_with_a_blackboard_check(tmp_path):
    tree = write(tmp_path, "g.yaml", """\
        version: 1
        name: g
        root:
          guard: while_built
          while: {key: /task/asbuilt, op: exists}
          child: {skill: move_to, name: up, params: {offset: [0.0, 0.0, 0.05]}}
        """)
    xml = write(tmp_path, "g.xml", export_tree(tree, tmp_path))
    XSD.validate(str(xml))
    assert '<BlackboardCheck name="while_built.while" key="/task/asbuilt" op="exists" />' in xml.read_text()
    back = write(tmp_path, "back.yaml", import_xml(xml, tmp_path / "back.yaml"))
    assert differences(load_tree(tree, dataflow=False), load_tree(back, dataflow=False)) == []


def test_a_reactive_sequence_is_a_guard_only_with_the_mark_and_a_file_s_old_guard_still_imports(tmp_path):
    """The exporter's mark is the condition's name `NAME.while`; other reactive sequences stay
    sequences; `<Guard _while>` (files exported before) still imports as a guard."""
    head = '<root BTCPP_format="4" main_tree_to_execute="t"><BehaviorTree ID="t">'
    child = '<move_to name="up" offset="0.0;0.0;0.05"/>'
    cases = {'<ReactiveSequence name="g"><ScriptCondition name="g.while" code="@gripper_width &gt; 0.01"/>'
             f'{child}</ReactiveSequence>': "guard",
             '<ReactiveSequence name="g"><ScriptCondition name="other" code="@gripper_width &gt; 0.01"/>'
             f'{child}</ReactiveSequence>': "sequence",
             f'<Guard name="g" _while="@gripper_width &gt; 0.01">{child}</Guard>': "guard"}
    for body, kind in cases.items():
        xml = write(tmp_path, "t.xml", head + body + "</BehaviorTree></root>")
        doc = load_tree(write(tmp_path, "t.yaml", import_xml(xml, tmp_path / "t.yaml")), dataflow=False)
        assert (doc.root.kind, doc.root.path) == (kind, "g")
        if kind == "guard":
            assert doc.root.args["while"] == {"key": "/gripper/width", "op": "gt", "value": 0.01}
            assert [c.path for c in doc.root.children] == ["g/up"]
