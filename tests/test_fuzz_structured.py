"""Structured fuzzing of the tree, design and cell files: near-valid documents, each the parse of a
shipped file with a few of its values changed the way an author (or an attacker) gets them wrong,
through the entry points a user hits. Unlike `test_fuzz_loaders.py`, which flips bytes and mostly
tests the YAML/JSON reader, these inputs parse: they test the field tables, the validator, the
design checks, the cell builders and the run they start.

A mutation picks a place in the document (any mapping value or list item) and replaces it with a
wrong type, null, a huge, tiny or negative number, a number written as a string, a list or a
mapping where a scalar belongs, a `$` reference, a deeply nested flow list, or adds a key from
the real field tables (top level, cell, subtree, node kinds, skill params) with such a value, or
a null key. Each input:

- tree: `load_tree` (what `fvtree validate|show|run` call first); a tree that loads is then
  run on the simulated cell for 0.1 s of cell time (open, first ticks, summary);
- design: `DesignModel.load`, then a copy of trees/assembly.yaml naming it is loaded and run
  like a tree;
- cell: `drivers.cell_builders.validate` (`fvtree validate --cell`); a simulated cell that
  validates runs trees/hold.yaml for 0.1 s of cell time.

The property: it loads (and its run ends with a status, never CRASHED, and no fault quoting a
Python exception), or raises the project's error (`FvtreeError`) naming the file; never another
exception, never a hang (`TIMEOUT_S` of CPU time per input). Examples per kind from
FVTREE_FUZZ_EXAMPLES: one number for all three kinds, or `trees=3000,designs=1000,cells=1000`;
the default keeps `make test` short. The reproducers of what fuzzing found are at the end.
"""

from __future__ import annotations

import copy
import json
import os
import re
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from test_fuzz_loaders import Workspace, time_limit

from fvfiles.errors import FvtreeError, FvtreeErrors

ROOT = Path(__file__).resolve().parents[1]
TIMEOUT_S = 10  # s of CPU time per input (load and run): far beyond any honest one
DEFAULT_EXAMPLES = {"trees": 70, "designs": 40, "cells": 40}  # about 35 s on two loaded cores
RUN_TIME_S = 0.1  # s of cell time a loaded input runs for


def examples(kind: str) -> int:
    """Examples for `kind` (trees, designs, cells) from FVTREE_FUZZ_EXAMPLES, else the default."""
    given_counts = os.environ.get("FVTREE_FUZZ_EXAMPLES", "").strip()
    if not given_counts:
        return DEFAULT_EXAMPLES[kind]
    if given_counts.isdigit():
        return int(given_counts)
    counts = dict(part.split("=") for part in given_counts.split(","))
    return int(counts.get(kind, DEFAULT_EXAMPLES[kind]))


def _field_names() -> list[str]:
    """Every field name of the tree language: top level, cell, subtree, node kinds, skill params."""
    from assembly.language.fields import CELL_FIELDS, SUBTREE_FIELDS, TOP_FIELDS
    from assembly.language.kinds import NODE_KINDS
    from behaviours.skill_kit.registry import SKILLS

    names = {*TOP_FIELDS, *CELL_FIELDS, *SUBTREE_FIELDS, *NODE_KINDS, "type", "default", "doc", "unit"}
    for kind in NODE_KINDS.values():
        names |= set(kind.fields)
    for skill in SKILLS.values():
        names |= set(skill.PARAMS) | {skill.NAME}
    return sorted(names)


def _cell_field_names() -> list[str]:
    """Every field of the shipped cell files, at any depth."""
    names: set[str] = set()

    def walk(value: Any) -> None:
        if isinstance(value, dict):
            names.update(map(str, value))
            for child in value.values():
                walk(child)
    for path in (ROOT / "drivers" / "cells").glob("*.yaml"):
        walk(yaml.safe_load(path.read_text()))
    return sorted(names)


DESIGN_FIELDS = ["id", "kind", "size", "pick_pose", "plate", "mass", "planned_pose", "status", "asbuilt_pose",
                 "measured_load", "cell", "origin", "span", "width", "source", "target", "nodes", "edges", "links",
                 "directed", "multigraph", "graph", "sim_load"]
STRINGS = ["", "1", "0.085", "-1", "1e400", "nan", ".nan", "inf", "true", "null", "~", "$", "$x", "$$at", "${at}",
           "$scan_step", "$at", "E1", "P1", "element", "plate", "placed", "../../etc/passwd", "/etc/passwd",
           "design/two_bays.json", "subtrees/prop_plate.yaml", "a\u200bb", "гр", "x" * 300, "*", "/fv/left.slip"]
NUMBERS = [0, -1, 1, 2, -0.0, 1e308, -1e308, 5e-324, 1e-300, 2**63, -(2**63), 10**30, 3.141593, 0.085, 1000, 1e6]


def scalars() -> st.SearchStrategy:
    """Wrong scalars: null, booleans, extreme and ordinary numbers, numbers as strings, refs."""
    return st.one_of(st.none(), st.booleans(), st.sampled_from(NUMBERS), st.integers(-(2**70), 2**70),
                     st.floats(allow_nan=False, allow_infinity=False), st.sampled_from(STRINGS),
                     st.text(max_size=6))


def values(keys: list[str]) -> st.SearchStrategy:
    """Scalars, and lists and mappings of them (keys from `keys`), a few levels deep."""
    return st.recursive(scalars(), lambda inner: st.one_of(
        st.lists(inner, max_size=7),
        st.dictionaries(st.one_of(st.sampled_from(keys), st.text(max_size=5)), inner, max_size=3)), max_leaves=10)


class Raw(str):
    """Text put into the dumped YAML as it is (deeply nested flow lists, which no dumper writes)."""


def _places(doc: Any) -> list[tuple[Any, Any]]:
    """(container, key or index) of every value in `doc`, depth first."""
    out: list[tuple[Any, Any]] = []
    stack = [doc]
    while stack:
        node = stack.pop()
        items = list(node.items()) if isinstance(node, dict) else list(enumerate(node)) if isinstance(node, list) else []
        for key, child in items:
            out.append((node, key))
            stack.append(child)
    return out


@st.composite
def mutated(draw: st.DrawFn, doc: Any, keys: list[str]) -> Any:
    """`doc` with one to three of its values changed (see the module's docstring)."""
    doc = copy.deepcopy(doc)
    for _ in range(draw(st.integers(1, 3))):
        places = _places(doc)
        if not places:
            break
        container, key = places[draw(st.integers(0, len(places) - 1))]
        op = draw(st.sampled_from(["replace", "replace", "delete", "add", "as_string", "in_list", "ref", "nested",
                                   "null_key", "scale", "scale", "copy"]))
        old = container[key]
        if op == "replace":
            container[key] = draw(values(keys))
        elif op == "delete":
            del container[key]
        elif op == "add" and isinstance(container, dict):
            container[draw(st.sampled_from(keys))] = draw(values(keys))
        elif op == "as_string" and not isinstance(old, (dict, list)):
            container[key] = str(old)
        elif op == "in_list":
            container[key] = [old] * draw(st.integers(0, 2))
        elif op == "ref":
            container[key] = "$" + draw(st.sampled_from(keys))
        elif op == "nested":
            depth = draw(st.sampled_from([50, 99, 100, 101, 150, 1000, 50_000]))
            container[key] = Raw("[" * depth + "1" + "]" * depth)
        elif op == "null_key" and isinstance(container, dict):
            container[None] = old
        elif op == "scale" and isinstance(old, (int, float)) and not isinstance(old, bool):
            container[key] = old * draw(st.sampled_from([-1, 0, 0.5, 2, 10, 1e3, 1e300, 1e-300]))
        elif op == "copy":  # a value of the right kind in the wrong place: a pose for a speed, a node for a param
            source, source_key = places[draw(st.integers(0, len(places) - 1))]
            container[key] = copy.deepcopy(source[source_key])
    return doc


def _placeholders(doc: Any, key: Callable[[Any], Any]) -> tuple[Any, list[str]]:
    """`doc` with each `Raw` value replaced by a placeholder `RAW<i>RAW` (keys through `key`), and the raw texts."""
    raws: list[str] = []

    def swap(value: Any) -> Any:
        if isinstance(value, Raw):
            raws.append(str(value))
            return f"RAW{len(raws) - 1}RAW"
        if isinstance(value, dict):
            return {key(k): swap(v) for k, v in value.items()}
        if isinstance(value, list):
            return [swap(v) for v in value]
        return value
    return swap(doc), raws


def dump_yaml(doc: Any) -> str:
    """YAML text of `doc`, with each `Raw` value written as it is."""
    swapped, raws = _placeholders(doc, lambda k: k)
    text = yaml.safe_dump(swapped, sort_keys=False, allow_unicode=True, width=10_000)
    return re.sub(r"RAW(\d+)RAW", lambda m: raws[int(m.group(1))], text)


def dump_json(doc: Any) -> str:
    """JSON text of `doc` (Raw values written as they are; NaN and Infinity as Python writes them)."""
    swapped, raws = _placeholders(doc, lambda k: "null" if k is None else str(k))
    return re.sub(r'"RAW(\d+)RAW"', lambda m: raws[int(m.group(1))], json.dumps(swapped, indent=1))


# ---- the entry points -------------------------------------------------------------------------------------
PYTHON_ERROR = re.compile(r"\b(?:[A-Z]\w*Error|[A-Z]\w*Exception|Traceback)\b")


def run_briefly(tree: Path | Any, cell: str = "sim") -> None:
    """Open a run of `tree` on `cell`, tick it for RUN_TIME_S of cell time and summarize it: it ends
    with a status, not CRASHED and with no fault quoting a Python exception."""
    from assembly.run.options import RunOptions
    from assembly.run.session import Run

    options = RunOptions(cell=cell, runs_dir=None, quiet=True, record=False, plots=False, max_time=RUN_TIME_S)
    with Run(tree, options) as run:
        summary = run.finish(run.loop())
    said = " ".join(str(s) for s in (summary.message, summary.arm_fault, summary.gripper_fault) if s)
    assert summary.status != "CRASHED", f"run crashed: {summary.message}\n{summary.traceback}"
    assert not PYTHON_ERROR.search(said), f"run ended {summary.status} quoting a Python exception: {said}"


def located_or_loaded(what: str, text: str, action) -> None:
    """`action()` succeeds or raises FvtreeError(s) that name a file, within TIMEOUT_S of CPU time."""
    try:
        with time_limit(TIMEOUT_S):
            action()
    except FvtreeError as exc:
        errors = exc.errors if isinstance(exc, FvtreeErrors) else [exc]
        assert all(e.file for e in errors), f"{what}: unlocated {exc}\n--- input:\n{text[:3000]}"
    except BaseException as exc:
        raise AssertionError(f"{what}: {type(exc).__name__}: {exc}\n--- input:\n{text[:3000]}") from exc


def check_tree(space: Workspace, text: str, include: bool = False) -> None:
    """`text` as a tree file or, `include`, as the subtrees file trees/assembly.yaml includes."""
    from assembly.language.reader import load_tree

    if include:
        (space.work / "trees" / "subtrees" / "fuzz.yaml").write_text(text)
        path = space.work / "trees" / "fuzz_include_tree.yaml"
        path.write_text((ROOT / "trees" / "assembly.yaml").read_text().replace("subtrees/prop_plate.yaml",
                                                                                 "subtrees/fuzz.yaml"))
    else:
        path = space.write("tree", text.encode())

    def action() -> None:
        run_briefly(load_tree(path))
    located_or_loaded("tree", text, action)


def check_design(space: Workspace, text: str) -> None:
    from assembly.design.model import DesignModel
    from assembly.language.reader import load_tree

    path = space.write("design", text.encode())
    tree = space.work / "trees" / "fuzz_design_tree.yaml"
    tree.write_text((ROOT / "trees" / "assembly.yaml").read_text().replace("design/two_bays.json", "design/fuzz.json"))

    def action() -> None:
        DesignModel.load(path)
        run_briefly(load_tree(tree))
    located_or_loaded("design", text, action)


def check_cell(space: Workspace, text: str) -> None:
    from drivers.cell_builders import validate

    path = space.write("cell", text.encode())

    def action() -> None:
        if validate(str(path))["kind"] == "sim":
            run_briefly(ROOT / "trees" / "hold.yaml", str(path))
    located_or_loaded("cell", text, action)


# ---- the property, by hypothesis --------------------------------------------------------------------------
INCLUDES = ["subtrees/prop_plate.yaml"]  # fuzzed as the file trees/assembly.yaml includes
TREE_SEEDS = sorted(p.name for p in (ROOT / "trees").glob("*.yaml")) + INCLUDES * 3
DESIGN_SEEDS = sorted(p.name for p in (ROOT / "trees" / "design").glob("*.json"))
SIM_CELL_SEEDS = ["sim.yaml", "sim_calibration.yaml"]
CELL_SEEDS = sorted(p.name for p in (ROOT / "drivers" / "cells").glob("*.yaml"))


def fuzz(kind: str) -> settings:
    """Seeded (derandomized) settings. No wall-clock deadline (a loaded machine would trip it):
    `time_limit` bounds each input's CPU time. A failure is reported with its input as found;
    FVTREE_FUZZ_SHRINK=1 also shrinks it (minutes: every step loads and runs)."""
    phases = [Phase.explicit, Phase.generate] + ([Phase.shrink] if os.environ.get("FVTREE_FUZZ_SHRINK") else [])
    return settings(max_examples=examples(kind), deadline=None, derandomize=True, database=None, phases=phases,
                    suppress_health_check=list(HealthCheck))


@pytest.fixture(scope="module")
def space(tmp_path_factory) -> Workspace:
    return Workspace(ROOT, tmp_path_factory.mktemp("fuzz_structured"))


def _seed_doc(folder: Path, name: str) -> Any:
    text = (folder / name).read_text()
    return json.loads(text) if name.endswith(".json") else yaml.safe_load(text)


TREE_KEYS, CELL_KEYS = _field_names(), _cell_field_names()
TREE_DOCS = {name: _seed_doc(ROOT / "trees", name) for name in TREE_SEEDS}
DESIGN_DOCS = {name: _seed_doc(ROOT / "trees" / "design", name) for name in DESIGN_SEEDS}
CELL_DOCS = {name: _seed_doc(ROOT / "drivers" / "cells", name) for name in CELL_SEEDS}
# the simulated cells twice: they are the ones that run
CELL_CHOICES = CELL_SEEDS + SIM_CELL_SEEDS


@fuzz("trees")
@given(data=st.data())
def test_near_valid_trees_load_or_give_a_located_error(space, data):
    seed = data.draw(st.sampled_from(TREE_SEEDS), label="seed")
    check_tree(space, dump_yaml(data.draw(mutated(TREE_DOCS[seed], TREE_KEYS), label="tree")), include=seed in INCLUDES)


@fuzz("designs")
@given(data=st.data())
def test_near_valid_designs_load_or_give_a_located_error(space, data):
    doc = DESIGN_DOCS[data.draw(st.sampled_from(DESIGN_SEEDS), label="seed")]
    check_design(space, dump_json(data.draw(mutated(doc, DESIGN_FIELDS), label="design")))


@fuzz("cells")
@given(data=st.data())
def test_near_valid_cell_files_load_or_give_a_located_error(space, data):
    doc = CELL_DOCS[data.draw(st.sampled_from(CELL_CHOICES), label="seed")]
    check_cell(space, dump_yaml(data.draw(mutated(doc, CELL_KEYS), label="cell")))


# ---- what fuzzing found, as reproducers -------------------------------------------------------------------
def _cell_with(tmp_path: Path, old: str, new: str) -> Path:
    text = (ROOT / "drivers" / "cells" / "sim.yaml").read_text()
    assert old in text
    path = tmp_path / "cell.yaml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(("old", "new", "field"), [
    ("  profile: fingervision_default", "  noise_px: '1'", "sensor.noise_px"),  # was UFuncTypeError at build
    ("max_width: 0.085", "max_width: '0.085'", "gripper.max_width"),  # validated, FAULTed at once, crashed the summary
    ("max_width: 0.085", "max_width: {}", "gripper.max_width"),
    ("gel_stiffness: 5000.0", "gel_stiffness: $max_speed", "gripper.gel_stiffness"),  # was TypeError at build
    ("friction: 0.8", "friction: {}", "world.friction"),  # validated, then the run CRASHED (TypeError)
    ("friction: 0.8", "friction: true", "world.friction"),
    ("  profile: fingervision_default", "  camera_fps: '30'", "sensor.camera_fps"),
    ("  profile: fingervision_default", "  normal_mode: sideways", "sensor.normal_mode"),
])
def test_a_cell_value_of_the_wrong_type_is_refused_with_its_field(tmp_path, old, new, field):
    from drivers.cell_builders import validate
    from drivers.cell_file import CellFileError

    path = _cell_with(tmp_path, old, new)
    with pytest.raises(CellFileError) as caught:
        validate(str(path))
    assert (caught.value.file, caught.value.field) == (str(path), field)
    assert caught.value.line == next(i for i, line in enumerate(path.read_text().splitlines(), 1)
                                     if line.strip().startswith(field.split(".")[1] + ":"))


def test_every_simulated_cell_setting_has_its_value_checked():
    from drivers.sim.cell import GRIPPER_VALUES
    from drivers.sim.devices.gripper import SimGripper
    from drivers.sim.scenes import SENSOR_FIELDS, SENSOR_VALUES, WORLD_FIELDS, WORLD_VALUES

    assert set(SENSOR_VALUES) == SENSOR_FIELDS
    assert set(WORLD_VALUES) == WORLD_FIELDS
    assert set(GRIPPER_VALUES) == set(SimGripper.__init__.__code__.co_varnames[1:5]) - {"width"}


def test_a_subtree_param_named_null_is_refused_at_its_line(tmp_path):
    """A `null:` key among a subtree's params, with `$` references in its body (was TypeError)."""
    from assembly.errors import TreeErrors
    from assembly.language.reader import load_tree

    text = (ROOT / "trees" / "classify_substance.yaml").read_text().replace(
        "      at: {type: vector, doc: pose above the bowl}", "      null: {type: vector, doc: pose above the bowl}")
    path = tmp_path / "tree.yaml"
    path.write_text(text)
    shutil.copytree(ROOT / "trees" / "models", tmp_path / "models")
    with pytest.raises(TreeErrors) as caught:
        load_tree(path)
    line = text.splitlines().index("      null: {type: vector, doc: pose above the bowl}") + 1
    assert any(e.line == line and "param name 'None' is not a name" in e.message for e in caught.value.errors)
    assert all(e.file == str(path) for e in caught.value.errors)


@pytest.mark.parametrize(("old", "new", "message"), [
    ('"id": "E1", "kind": "element"', '"id": "E1", "kind": []', "kind must be 'element' or 'plate'"),
    ('"pick_pose": [0.30, -0.45, 0.02, 0.0, 0.0, 0.0]', '"pick_pose": [0.30, -0.45, 0.02, 1e308, 0.0, 0.0]',
     "must be at most 10"),
])
def test_a_design_found_by_fuzzing_is_refused_before_the_run(tmp_path, old, new, message):
    """An element `kind: []` (was TypeError) and a pick_pose rotation of 1e308 (validated, then a
    math domain error before the first tick)."""
    from assembly.design.model import DesignModel
    from assembly.errors import TreeError

    text = (ROOT / "trees" / "design" / "two_bays.json").read_text()
    assert old in text
    path = tmp_path / "design.json"
    path.write_text(text.replace(old, new))
    with pytest.raises(TreeError) as caught:
        DesignModel.load(path)
    assert message in str(caught.value) and caught.value.file == str(path) and caught.value.line == 8  # E1


@pytest.mark.parametrize("text", ["[" * 500_000, "[" * 250_000 + "]" * 250_000, "{a: " * 200_000])
def test_deeply_nested_flow_input_is_refused_at_once(tmp_path, text):
    """A line of brackets is refused by the scanner at the 101st level. Before, PyYAML's scanner
    looked ahead for a simple key at every bracket first: 0.23 s of CPU per file, seconds when
    loaded; now about 2 ms. CPU time, not wall time: what a loaded machine does not change."""
    from assembly.errors import TreeErrors
    from assembly.language.reader import load_tree

    path = tmp_path / "deep.yaml"
    path.write_text("version: 1\nname: deep\nroot: " + text + "\n")
    started = time.process_time()
    with pytest.raises(TreeErrors, match="nested more than 100 levels deep"):
        load_tree(path)
    assert time.process_time() - started < 0.05
