"""The contract every registered skill must pass, checked skill by skill (in the spirit of
scikit-learn's `check_estimator`): its declared params validate and refuse bad values with a
located error, it stops the arm and the gripper when halted, every key it reads has a writer,
it ends by itself within a bound (or declares that it runs until halted), and it is documented
and demonstrated. A new skill gets all of these checks by being registered."""

from __future__ import annotations

import ast
import json
import re
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from py_trees.blackboard import ActivityStream, Blackboard
from py_trees.common import Status

from assembly.design.model import DesignModel
from assembly.errors import TreeErrors
from assembly.language.catalogue import describe_skills
from assembly.language.reader import load_tree
from assembly.language.schema import tree_schema
from assembly.run.perception_stage import clear_blackboard
from assembly.testing import TreeHarness, mock_cell, touch
from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, Skill
from behaviours.skill_kit.registry import SKILLS

ROOT = Path(__file__).resolve().parents[1]
DESIGN = DesignModel.load(ROOT / "trees" / "design" / "two_bays.json")
NAMES = sorted(SKILLS)

# Params a skill cannot do without (no usable default), and the blackboard a skill finds in
# its demo tree: the element being built and the plates of the design.
NEEDED = {"move_to": {"offset": [0.0, 0.0, 0.02]}}
TASK = {keys.ELEMENT: DESIGN.element("E1"), keys.PLATES: DESIGN.plates()}

TICK_HZ = 10  # few ticks per second of cell time keeps the bound checks fast
MAX_TICKS = 3000  # 300 s of cell time: longer than any skill's bound at its defaults


def tree_text(skill: str, params: dict[str, Any]) -> str:
    """A tree with the skill under a sequence, params written as YAML flow (JSON)."""
    return (f"version: 1\nname: contract\ncell: {{tick_hz: {TICK_HZ}}}\nroot:\n  sequence: main\n"
            f"  memory: true\n  children:\n    - {{skill: {skill}, name: s, params: {json.dumps(params)}}}\n")


def harness(skill: str, script) -> TreeHarness:
    """The skill, with its defaults, on the mocked cell (an object between the fingers) with the
    task on the blackboard and perception from `script`."""
    cell = mock_cell(TICK_HZ, gripper_width=0.06, object_width=0.04)
    h = TreeHarness.from_text(tree_text(skill, NEEDED.get(skill, {})), cell=cell)
    for key, value in TASK.items():
        h.set(key, value)
    return h.script(script)


# A few ways of holding an object that the fingertips can feel (the torque twists the hand
# about the closing axis, so it has opposite signs on the two pads); the scripts replay them.
FELT = {
    "held": {"normal": 5.0, "area": 0.3},
    "pressed": {"normal": 15.0, "shear": (2.0, 1.0), "area": 0.3},
    "slipping": {"normal": 5.0, "area": 0.3, "slip": 0.1},
    "twisted": {"normal": 5.0, "area": 0.25, "torque": 0.05, "orientation": 0.3},
    "twisted back": {"normal": 5.0, "area": 0.25, "torque": -0.05, "orientation": -0.3},
    "off centre": {"normal": 2.0, "area": 0.1, "centroid": (0.3, -0.2)},
}
STATES = {name: {f: touch(f, **{**kw, "torque": sign * kw.get("torque", 0.0)})
                 for f, sign in (("left", 1.0), ("right", -1.0))} for name, kw in FELT.items()}


def held(tick: int, t: float) -> dict:
    """An object held still between the fingers: what a skill waiting for change sees forever."""
    return STATES["held"]


def rocking(tick: int, t: float) -> dict:
    """An object rocking in the hand: a torque that never vanishes but changes sign each tick."""
    return STATES["twisted" if tick % 2 else "twisted back"]


def jitter(skill: str):
    """Each tick, one of the felt states at random (seeded by the skill): the object stays in the
    hand but settle counters reset and thresholds are crossed back and forth."""
    rng = np.random.default_rng(zlib.crc32(skill.encode()))
    names = list(STATES)
    return lambda tick, t: STATES[names[rng.integers(len(names))]]


# ---- (a) defaults validate -----------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_defaults_validate(name):
    cls = SKILLS[name]
    params = cls.resolve_params(NEEDED.get(name, {}))
    for key, decl in cls.PARAMS.items():
        assert decl.doc, f"{name}.{key} has no description"
        if not decl.required and decl.default is not None:
            assert decl.check(decl.default) == decl.default, f"{name}.{key}: default fails its own check"
    assert set(params) == set(cls.PARAMS)


# ---- (b) invalid values are refused, naming the param, with a located tree error ------------
def invalid_values(decl: Param) -> list[tuple[str, Any]]:
    """(what is wrong, value) for every way a value can break the declaration."""
    bad: list[tuple[str, Any]] = [("wrong type", 1.5 if decl.type == "str" else "text")]
    if decl.type == "vector":
        n = decl.length or 3
        bad.append(("wrong length", [0.0] * (n + 1)))
    n = (decl.length or 1) if decl.type == "vector" else None
    for bound, step, what in ((decl.min, -1, "below min"), (decl.max, 1, "above max")):
        if bound is not None and decl.type in ("float", "int", "vector"):
            value = int(bound) + step if decl.type == "int" else bound + step
            bad.append((what, [float(value)] * n if n else value))
    if decl.choices:
        bad.append(("not a choice", "no_such_choice"))
    return bad


@pytest.mark.parametrize("name", NAMES)
def test_invalid_values_are_refused_with_a_located_error(name):
    cls = SKILLS[name]
    problems = []
    for key, decl in cls.PARAMS.items():
        for what, value in invalid_values(decl):
            params = {**NEEDED.get(name, {}), key: value}
            try:
                cls.resolve_params(params)
                problems.append(f"{key} {what} {value!r}: accepted")
            except ValueError as exc:
                if repr(key) not in str(exc):
                    problems.append(f"{key} {what}: message does not name the param: {exc}")
            with pytest.raises(TreeErrors) as caught:
                load_tree(text=tree_text(name, params), name="contract.yaml")
            located = [e for e in caught.value.errors
                       if e.file == "contract.yaml" and e.line == 8 and e.path == "main/s" and repr(key) in e.message]
            if not located:
                problems.append(f"{key} {what}: not located at contract.yaml:8 main/s: {caught.value}")
    assert not problems, f"{name}:\n" + "\n".join(problems)


# ---- (c) halted mid-run, the arm and the gripper stand still -------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_halting_stops_the_arm_and_the_gripper(name):
    """Halted by its parent, as a selector or a timeout does: only the skill's own `terminate`
    runs (`TreeHarness.halt` would stop the devices itself, hiding a skill that does not)."""
    h = harness(name, lambda tick, t: STATES["slipping"])
    h.cell.estop = SKILLS[name].RUNS_UNTIL_HALTED  # keeps estop_guard running
    for _ in range(50):
        h.tick()
        if h.status("main/s") != "RUNNING":
            pytest.fail(f"{name} ended ({h.status('main/s')}: {h.feedback('main/s')!r}) before commanding anything")
        if h.arm.commands or h.gripper.commands:
            break
    else:
        pytest.fail(f"{name} commanded nothing in 50 ticks")
    h.tree.root.stop(Status.INVALID)
    assert h.status("main/s") == "INVALID"
    assert not h.arm.is_moving() and not h.gripper.is_moving()
    last = {device: [c.name for c in commands[-1:]] for device, commands in
            (("arm", h.arm.commands), ("gripper", h.gripper.commands))}
    assert last == {"arm": ["stop"], "gripper": ["stop"]}, f"{name}: last commands {last}"


# ---- (d) every key read has a writer ---------------------------------------------------------------
WRITTEN = set(keys.PERCEPTION_KEYS) | set(keys.TASK_KEYS) | {k for cls in SKILLS.values() for k in cls.WRITES}


@pytest.mark.parametrize("name", NAMES)
def test_every_key_read_has_a_writer(name):
    cls = SKILLS[name]
    assert not set(cls.READS) - WRITTEN, f"{name} reads keys nothing writes: {sorted(set(cls.READS) - WRITTEN)}"
    assert len(set(cls.READS)) == len(cls.READS) and len(set(cls.WRITES)) == len(cls.WRITES)


# ---- robot state comes from the tick's snapshot, never from the devices -------------------------
DEVICE_READS = {"pose", "width", "is_moving", "fault", "object_detected", "tcp_wrench", "tcp_speed"}


@pytest.mark.parametrize("module", sorted(p.name for p in (ROOT / "behaviours").glob("*.py")))
def test_skills_read_no_device_state(module):
    """A read on the device in the middle of a tick may see a newer state than the snapshot
    the other skills of that tick see; the snapshot helpers (`self.pose()`, ...) are the way."""
    tree = ast.parse((ROOT / "behaviours" / module).read_text())
    calls = [f"line {node.lineno}: {ast.unparse(node)}" for node in ast.walk(tree)
             if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
             and node.func.attr in DEVICE_READS
             and not (isinstance(node.func.value, ast.Name) and node.func.value.id in ("self", "skill"))]
    assert not calls, f"behaviours/{module} reads the devices: " + "; ".join(calls)


def test_an_undeclared_read_is_refused():
    class Undeclared(SKILLS["move_to"]):
        READS = ()
    skill = Undeclared("s", offset=[0.0, 0.0, 0.01])
    with pytest.raises(AttributeError):
        skill.pose()
    with pytest.raises(AttributeError):
        skill.read(keys.ROBOT_POSE, "default")


def test_reads_give_the_value_or_the_default_whether_direct_or_through_the_client():
    clear_blackboard()
    skill = SKILLS["move_to"]("s", offset=[0.0, 0.0, 0.01])
    Blackboard.storage[keys.ROBOT_POSE] = None
    for recording in (False, True):  # py_trees' activity stream on: every read goes through the client
        Blackboard.activity_stream = ActivityStream() if recording else None
        try:
            assert skill.read(keys.ROBOT_FAULT, "unset") == "unset"
            assert skill.read(keys.ROBOT_POSE, "unset") is None  # set to None: None, not the default
            with pytest.raises(KeyError):
                skill.reads[keys.ROBOT_FAULT]
            assert not recording or Blackboard.activity_stream.data  # recorded: the reads are in the stream
        finally:
            Blackboard.activity_stream = None
    clear_blackboard()


# ---- (e) it ends by itself within a bound, or says it runs until halted ---------------------------
@pytest.mark.parametrize("script", ["held", "rocking", "jitter"])
@pytest.mark.parametrize("name", NAMES)
def test_ends_by_itself_within_a_bound(name, script):
    cls = SKILLS[name]
    if cls.runs_until_halted(cls.resolve_params(NEEDED.get(name, {}))):
        assert cls.RUNS_UNTIL_HALTED, f"{name} runs until halted at its defaults"
        return
    h = harness(name, {"held": held, "rocking": rocking}.get(script) or jitter(name))
    status = h.run_until_done(MAX_TICKS)
    assert status in (Status.SUCCESS, Status.FAILURE)
    assert not h.arm.is_moving() or h.arm.fault(), f"{name} ended ({status.name}) with the arm still moving"


# ---- (f) documented and demonstrated ---------------------------------------------------------------
README = (ROOT / "README.md").read_text()
SKILL_TABLE = "\n".join(line for line in README.splitlines() if line.startswith("| `"))
SCHEMA = json.dumps(tree_schema())


def uses(tree: Path, name: str) -> bool:
    try:
        return re.search(rf"skill: {name}\b", tree.read_text()) is not None
    except FileNotFoundError:  # deleted since it was listed
        return False


@pytest.mark.parametrize("name", NAMES)
def test_documented_and_demonstrated(name):
    assert name in describe_skills()
    assert f'"skill": {{"const": "{name}"}}' in SCHEMA, f"{name} is missing from the tree schema"
    assert re.search(rf"`{name}`", SKILL_TABLE), f"{name} is missing from README.md's skill table"
    assert any(uses(tree, name) for tree in (ROOT / "trees").rglob("*.yaml")), f"no tree under trees/ uses {name}"


def test_the_skills_are_skills():
    assert all(issubclass(cls, Skill) and cls.NAME == name and cls.SUMMARY for name, cls in SKILLS.items())
