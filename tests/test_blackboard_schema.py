"""The blackboard keys as a checked schema: generated from the types that fill them, published in the
JSON Schema and the README, and enforced by the validator on conditions and guards."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import jsonschema
import pytest

from assembly.errors import TreeErrors
from assembly.language.blackboard import blackboard_tables, field_paths, key_problem, key_schemas
from assembly.language.reader import load_tree
from assembly.language.schema import tree_schema
from assembly.nodes.conditions import split_key
from behaviours.skill_kit import keys
from perception.state import MarkerField, ObjectInfo, TactileState

README = Path(__file__).parents[1] / "README.md"


def tree(condition: str) -> str:
    return ("version: 1\nname: t\ncell: {scene: hold}\nroot:\n  sequence: s\n  memory: true\n  children:\n"
            f"    - {{condition: c, {condition}}}\n")


def test_the_readme_tables_are_the_generated_ones():
    text = README.read_text()
    found = re.search(r"<!-- blackboard tables: [^\n]*-->\n(.*?)<!-- end of blackboard tables -->", text, re.DOTALL)
    assert found, "the README has no generated blackboard tables"
    assert found.group(1) == blackboard_tables(), \
        "regenerate the README's tables with assembly.language.blackboard.blackboard_tables()"


def test_every_field_of_the_perception_types_is_in_the_schema_with_a_meaning():
    finger = key_schemas()[keys.FV_LEFT]["properties"]
    for cls, fields in ((TactileState, finger), (MarkerField, finger["markers"]["properties"]),
                        (ObjectInfo, finger["obj"]["properties"])):
        for f in dataclasses.fields(cls):
            assert f.name in fields and fields[f.name]["description"], f"{cls.__name__}.{f.name}"
    assert set(keys.PERCEPTION_KEYS) | set(keys.TASK_KEYS) <= set(key_schemas())
    assert "/fv/left.obj.present" in field_paths() and "/fv/left.object.present" not in field_paths()
    assert "/task/element.plate" in field_paths() and "/task/plates.<id>.span" in field_paths()


def test_the_published_json_schema_is_valid_and_offers_every_field_path():
    schema = tree_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["$defs"]["blackboard"]["properties"][keys.FV_RIGHT]["properties"]["obj"]["title"] == "ObjectInfo"
    assert "/fv/right.force" in schema["$defs"]["condition"]["properties"]["key"]["examples"]


@pytest.mark.parametrize("key, message, hint", [
    ("/fv/left.object.present", "/fv/left (TactileState) has no field 'object'", "did you mean 'obj'?"),
    ("/fv/right.obj.presnt", "/fv/right.obj (ObjectInfo) has no field 'presnt'", "did you mean 'present'?"),
    ("/fv/left.force[3]", "/fv/left.force has 3 items: index [3] is out of range", "use 0 to 2"),
    ("/robot/pose[6]", "/robot/pose has 6 items: index [6] is out of range", "use 0 to 5"),
    ("/gripper/width.mm", "/gripper/width is number: it has no field 'mm'", None),
    ("/fv/left.slip[0]", "/fv/left.slip is not a list: it takes no index [0]", None),
])
def test_a_condition_on_a_field_that_is_not_there_is_refused_at_its_line(key, message, hint):
    with pytest.raises(TreeErrors) as caught:
        load_tree(text=tree(f'key: "{key}", op: exists'), name="t.yaml", dataflow=False)
    (error,) = caught.value.errors
    assert (error.message, error.hint, error.file, error.line) == (message, hint, "t.yaml", 8)


def test_a_guard_on_a_field_that_is_not_there_is_refused_at_its_line():
    text = ("version: 1\nname: t\ncell: {scene: hold}\nroot:\n  guard: watch\n"
            "  while: {key: /fv/left.object.present, op: eq, value: true}\n  child: {skill: hold, name: h}\n")
    with pytest.raises(TreeErrors) as caught:
        load_tree(text=text, name="t.yaml")
    (error,) = caught.value.errors
    assert (error.line, error.hint) == (6, "did you mean 'obj'?")


@pytest.mark.parametrize("key", ["/fv/left.obj.present", "/fv/right.markers.displacement[0][1]",
                                 "/robot/pose[-1]", "/task/element.size[2]", "/task/plates.P1.span",
                                 "/task/best_pose[2]", "/task/substance.label"])
def test_fields_that_are_there_and_keys_of_skill_defined_shape_pass(key):
    assert key_problem(*split_key(key)) is None
