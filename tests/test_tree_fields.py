"""The fields of a tree file are one table (`assembly.language.fields`) that both the loader and
`tree_schema()` read, so they agree: for each variation of a valid tree below, the loader accepts
the file if and only if the `jsonschema` library accepts it against the schema.

Where the schema cannot say it, they differ, and `DIFFERENT` says why for each case: the schema
sees one file and cannot tell the tree file loaded (which needs a name and a root) from an
included one (which need not have either); it cannot follow includes to other files; and a param's
default must fit the param's type, which JSON Schema cannot relate. Beyond these cases, the scene
names in the schema are those of the simulator (plug-ins included) when the schema was generated,
and a tolerance's name is checked against the scene when the tree runs, not when it is loaded.
"""

from __future__ import annotations

import copy
from collections.abc import Callable

import jsonschema
import pytest
import yaml

from assembly.errors import TreeErrors
from assembly.language.fields import CELL_FIELDS, SUBTREE_FIELDS, TOP_FIELDS
from assembly.language.reader import load_tree
from assembly.language.schema import tree_schema
from assembly.language.validator import PARAM_FIELDS

BASE = {
    "version": 1,
    "name": "t",
    "cell": {"tick_hz": 30, "scene": "assembly", "tolerances": {"max_regret": 0.01}},
    "subtrees": {"lift": {"doc": "lift a little", "params": {"speed": {"type": "float", "default": 0.1}},
                          "root": {"skill": "move_to", "name": "up",
                                   "params": {"offset": [0, 0, 0.1], "speed": "$speed"}}}},
    "root": {"subtree": "lift", "name": "go"},
}
INCLUDED = {"version": 1, "subtrees": {"lower": {"root": {"skill": "move_to", "name": "down",
                                                          "params": {"offset": [0, 0, -0.1]}}}}}


def _set(path: str, value: object) -> Callable[[dict], None]:
    """A change to the tree: the field at the dotted `path` set to `value`."""
    *parents, last = path.split(".")

    def change(tree: dict) -> None:
        for key in parents:
            tree = tree[key]
        tree[last] = value
    return change


def _drop(path: str) -> Callable[[dict], None]:
    """A change to the tree: the field at the dotted `path` removed."""
    *parents, last = path.split(".")

    def change(tree: dict) -> None:
        for key in parents:
            tree = tree[key]
        del tree[last]
    return change


def _both(first: Callable[[dict], None], second: Callable[[dict], None]) -> Callable[[dict], None]:
    """A change to the tree: two changes, one after the other."""
    return lambda tree: (first(tree), second(tree))


# (what, change, valid): loader and schema both accept the tree (valid) or both refuse it.
AGREE = [
    ("unchanged", lambda tree: None, True),
    ("name empty", _set("name", ""), False),
    ("name a number", _set("name", 3), False),
    ("name null", _set("name", None), False),
    ("doc a string", _set("doc", "what it does"), True),
    ("doc a number", _set("doc", 3), False),
    ("design empty", _set("design", ""), False),
    ("design a list", _set("design", ["d.json"]), False),
    ("version 2", _set("version", 2), False),
    ("version 1.0", _set("version", 1.0), True),
    ("version true", _set("version", True), False),
    ("version a string", _set("version", "1"), False),
    ("version missing", _drop("version"), False),
    ("unknown top-level field", _set("nmae", "t"), False),
    ("cell null", _set("cell", None), True),
    ("cell a list", _set("cell", [30]), False),
    ("cell unknown setting", _set("cell.tick", 30), False),
    ("tick_hz 0", _set("cell.tick_hz", 0), False),
    ("tick_hz 0.5", _set("cell.tick_hz", 0.5), True),
    ("tick_hz 1000", _set("cell.tick_hz", 1000), True),
    ("tick_hz 1001", _set("cell.tick_hz", 1001), False),
    ("tick_hz -30", _set("cell.tick_hz", -30), False),
    ("tick_hz a word", _set("cell.tick_hz", "fast"), False),
    ("tick_hz true", _set("cell.tick_hz", True), False),
    ("scene another", _set("cell.scene", "hold"), True),
    ("scene unknown", _set("cell.scene", "hodl"), False),
    ("scene a number", _set("cell.scene", 3), False),
    ("tolerance 0", _set("cell.tolerances.max_regret", 0), True),
    ("tolerance negative", _set("cell.tolerances.max_regret", -0.01), False),
    ("tolerance a word", _set("cell.tolerances.max_regret", "small"), False),
    ("tolerances null", _set("cell.tolerances", None), False),
    ("tolerances a list", _set("cell.tolerances", [0.01]), False),
    ("include a list of files", _set("include", ["sub.yaml"]), True),
    ("include empty", _set("include", []), True),
    ("include null", _set("include", None), True),
    ("include not a list", _set("include", "sub.yaml"), False),
    ("include a number", _set("include", [3]), False),
    ("include an empty name", _set("include", [""]), False),
    ("subtrees null", _both(_set("subtrees", None), _set("root", {"skill": "estop_guard"})), True),
    ("subtrees a list", _set("subtrees", ["lift"]), False),
    ("subtree not a mapping", _set("subtrees.lift", 3), False),
    ("subtree without root", _drop("subtrees.lift.root"), False),
    ("subtree unknown field", _set("subtrees.lift.rot", {}), False),
    ("subtree doc a number", _set("subtrees.lift.doc", 3), False),
    ("subtree params null", _both(_set("subtrees.lift.params", None), _drop("subtrees.lift.root.params.speed")),
     True),
    ("subtree params a list", _set("subtrees.lift.params", ["height"]), False),
    ("param a type name", _both(_set("subtrees.lift.params.speed", "float"), _set("root.params", {"speed": 0.2})),
     True),
    ("param an unknown type", _set("subtrees.lift.params.speed", "flot"), False),
    ("param a number", _set("subtrees.lift.params.speed", 3), False),
    ("param without type", _set("subtrees.lift.params.speed", {"default": 0.1}), False),
    ("param unknown field", _set("subtrees.lift.params.speed.colour", "red"), False),
    ("param unit", _set("subtrees.lift.params.speed.unit", "m/s"), True),
    ("param unit a number", _set("subtrees.lift.params.speed.unit", 3), False),
    ("param doc a list", _set("subtrees.lift.params.speed.doc", ["up"]), False),
    ("root not a node", _set("root", 3), False),
    ("not a mapping", lambda tree: tree.clear(), False),
]

INCLUDED_FILE = "an included file need not have it, and the schema cannot tell one from the tree file"
# (what, change, loads, why the schema says otherwise)
DIFFERENT = [
    ("name missing", _drop("name"), False, INCLUDED_FILE),
    ("root missing", _drop("root"), False, INCLUDED_FILE),
    ("include missing file", _set("include", ["nowhere.yaml"]), False, "the schema sees one file"),
    ("include itself", _set("include", ["tree.yaml"]), False, "the schema sees one file: an include cycle"),
    ("subtree defined twice", _set("include", ["twice.yaml"]), False, "the schema sees one file"),
    ("param default of another type", _set("subtrees.lift.params.speed.default", "high"), False,
     "JSON Schema cannot relate a default to the param's type"),
]


@pytest.fixture
def loads(tmp_path) -> Callable[[dict], bool]:
    """Whether the loader accepts a tree (written next to the files it may include)."""
    (tmp_path / "sub.yaml").write_text(yaml.safe_dump(INCLUDED))
    (tmp_path / "twice.yaml").write_text(yaml.safe_dump({"version": 1, "subtrees": {"lift": BASE["subtrees"]["lift"]}}))

    def load(tree: dict) -> bool:
        path = tmp_path / "tree.yaml"
        path.write_text(yaml.safe_dump(tree, sort_keys=False))
        try:
            load_tree(path)
        except TreeErrors:
            return False
        return True
    return load


@pytest.fixture(scope="module")
def schema_accepts() -> Callable[[dict], bool]:
    return jsonschema.Draft202012Validator(tree_schema()).is_valid


def _changed(change: Callable[[dict], None]) -> dict:
    tree = copy.deepcopy(BASE)
    change(tree)
    return tree


@pytest.mark.parametrize("what, change, valid", AGREE, ids=[case[0] for case in AGREE])
def test_loader_and_schema_agree(what, change, valid, loads, schema_accepts):
    tree = _changed(change)
    assert loads(tree) == valid, f"{what}: the loader {'refuses' if valid else 'accepts'} it"
    assert schema_accepts(tree) == valid, f"{what}: the schema {'refuses' if valid else 'accepts'} it"


@pytest.mark.parametrize("what, change, loaded, why", DIFFERENT, ids=[case[0] for case in DIFFERENT])
def test_where_the_schema_cannot_say_it(what, change, loaded, why, loads, schema_accepts):
    tree = _changed(change)
    assert loads(tree) == loaded
    assert schema_accepts(tree) != loaded, why


def test_an_included_file_needs_neither_name_nor_root(loads, schema_accepts):
    assert schema_accepts(INCLUDED)
    assert loads({**BASE, "include": ["sub.yaml"]})


def test_every_field_is_documented_in_one_line():
    for table in (TOP_FIELDS, CELL_FIELDS, SUBTREE_FIELDS):
        for key, field in table.items():
            assert field.doc and "\n" not in field.doc, key


def test_a_param_declaration_has_the_validator_fields():
    params = tree_schema()["properties"]["subtrees"]["additionalProperties"]["properties"]["params"]
    assert list(params["additionalProperties"]["anyOf"][1]["properties"]) == list(PARAM_FIELDS)


@pytest.mark.parametrize("text, message", [
    ("version: 1\nname: ''\nroot: {skill: estop_guard}\n", "t.yaml:2: name: must not be empty"),
    ("version: 1\nname: t\ncell: {tick_hz: 1001}\nroot: {skill: estop_guard}\n",
     "t.yaml:3: cell.tick_hz: must be at most 1000, got 1001 (ticks per second on the cell clock)"),
    ("version: 1\nname: t\ncell:\n  tolerances: {max_regret: -1}\nroot: {skill: estop_guard}\n",
     "t.yaml:4: cell.tolerances.max_regret: must be at least 0, got -1"),
    ("version: 1\nname: t\ncell: {tick: 30}\nroot: {skill: estop_guard}\n",
     "t.yaml:3: cell: unknown field 'tick' (did you mean 'tick_hz'?)"),
    ("version: 1\nnmae: t\nroot: {skill: estop_guard}\n", "t.yaml:2: unknown top-level field 'nmae' (did you mean 'name'?)"),
    ("version: 1\nroot: {skill: estop_guard}\n", "t.yaml:1: missing top-level field 'name'"),
    ("version: 1\nname: t\nsubtrees:\n  a: {rot: {}}\nroot: {skill: estop_guard}\n",
     "t.yaml:4: subtrees.a: unknown field 'rot' (did you mean 'root'?)"),
    ("version: 1\nname: t\nsubtrees:\n  a: {doc: x}\nroot: {skill: estop_guard}\n",
     "t.yaml:4: subtrees.a: missing field 'root' (the subtree's root node)"),
    ("version: 1\nname: t\ninclude: a.yaml\nroot: {skill: estop_guard}\n", "t.yaml:3: include: must be array or null"),
])
def test_messages_name_the_line_and_the_field(text, message):
    with pytest.raises(TreeErrors) as exc:
        load_tree(text=text, name="t.yaml")
    assert any(str(e).startswith(message) for e in exc.value.errors), [str(e) for e in exc.value.errors]
