"""The contract every skill keeps, as checks a skill author runs on their own skill (in the spirit
of scikit-learn's `check_estimator` and `parametrize_with_checks`):

    from assembly.testing import check_skill, parametrize_with_skill_checks

    check_skill(Pinch)                                    # one AssertionError listing every broken check
    check_skill(MoveTo, params={"offset": [0, 0, 0.02]})  # values for params it cannot do without

    @parametrize_with_skill_checks([Pinch])               # one pytest case per check
    def test_pinch_keeps_the_contract(check):
        check()

The checks (`skill_checks` yields them, each a named `SkillCheck`):

- `defaults_validate`: every param is described, every default passes its own declaration, and
  the skill can be made from its defaults (plus `params`).
- `invalid_values_refused`: each way a value can break a param's declaration (type, length, range,
  choices) is refused naming the param, and a tree holding it is refused with an error located
  at the file, line and node path.
- `halting_stops_the_devices`: halted mid-run by its parent (not by `TreeHarness.halt`, which
  stops the devices itself), the arm and the gripper stand still and their last commands are stops.
- `reads_have_writers`: every key in READS (but OPTIONAL_READS) is written by perception, the task
  or some skill; no key is declared twice.
- `reads_no_device_state`: the skill's module reads robot state from the tick's snapshot
  (`self.pose()`, ...), never from the devices (an AST scan for `arm.pose()` and the like).
- `ends_by_itself-held|rocking|jitter`: it ends within 300 s of cell time under each perception
  script, the arm still, or declares `RUNS_UNTIL_HALTED`.
- `documented`: registered under its NAME, with a SUMMARY, in `fvtree skills`' catalogue and in
  the tree JSON Schema.

The checks read only what the skill declares (PARAMS, READS, WRITES, RUNS_UNTIL_HALTED) and run it
alone in a tree on `mock_cell` (an object between the fingers) through `TreeHarness`, with one
element and its plate on the blackboard (/task/element, /task/plates). A skill not registered yet
is put in the skill table while a check loads its tree, and taken out after; `documented` reports
it. pytest is imported only by `parametrize_with_skill_checks`.
"""

from __future__ import annotations

import ast
import copy
import inspect
import json
import sys
import traceback
import zlib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np
from py_trees.common import Status

from assembly.errors import TreeErrors
from assembly.language.catalogue import describe_skills
from assembly.language.plugins import load_plugins
from assembly.language.reader import load_tree
from assembly.language.schema import tree_schema
from assembly.language.validator import known_blackboard_keys
from assembly.testing.harness import Command, RecordingArm, RecordingGripper, Script, TreeHarness, mock_cell, touch
from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, Skill
from behaviours.skill_kit.registry import SKILL_PACKAGES, SKILLS
from drivers.safe_gripper import SafeGripper
from drivers.safety import SafeArm
from fvfiles.errors import FvtreeError

if TYPE_CHECKING:
    import pytest

Params = Mapping[str, Any] | None

TICK_HZ = 10  # few ticks per second of cell time keeps the bound checks fast
MAX_TICKS = 3000  # 300 s of cell time: longer than any skill's bound at its defaults
HALT_WITHIN = 50  # ticks a skill has to command the arm or the gripper before it is halted
TREE_FILE = "contract.yaml"  # the name the checks' trees are loaded under
SKILL_PATH = "main/s"  # the skill's node path in them

# One plate propped by one element standing ready to be picked (the first bay of
# trees/design/two_bays.json): what a skill finds on the blackboard under for_each_element.
ELEMENT = {"id": "E1", "kind": "element", "plate": "P1", "size": [0.435, 0.04, 0.04], "mass": 0.4,
           "pick_pose": [0.30, -0.45, 0.02, 0.0, 0.0, 0.0], "status": "planned"}
PLATES = {"P1": {"kind": "plate", "origin": [-0.55, 0.30, 0.46], "span": 1.0, "width": 0.2}}

# Ways of holding an object that the fingertips can feel (the torque twists the hand about the
# closing axis, so it has opposite signs on the two pads); the scripts replay them.
FELT: dict[str, dict[str, Any]] = {
    "held": {"normal": 5.0, "area": 0.3},
    "pressed": {"normal": 15.0, "shear": (2.0, 1.0), "area": 0.3},
    "slipping": {"normal": 5.0, "area": 0.3, "slip": 0.1},
    "twisted": {"normal": 5.0, "area": 0.25, "torque": 0.05, "orientation": 0.3},
    "twisted back": {"normal": 5.0, "area": 0.25, "torque": -0.05, "orientation": -0.3},
    "off centre": {"normal": 2.0, "area": 0.1, "centroid": (0.3, -0.2)},
}


@cache
def felt(name: str) -> dict:
    """{finger: TactileState} of the way of holding `name` (made once, on first use: the contact
    model takes a while)."""
    kw = FELT[name]
    return {f: touch(f, **{**kw, "torque": sign * kw.get("torque", 0.0)}) for f, sign in (("left", 1.0), ("right", -1.0))}


def held(skill: str) -> Script:
    """An object held still between the fingers: what a skill waiting for change sees forever."""
    return lambda tick, t: felt("held")


def rocking(skill: str) -> Script:
    """An object rocking in the hand: a torque that never vanishes but changes sign each tick."""
    return lambda tick, t: felt("twisted" if tick % 2 else "twisted back")


def jitter(skill: str) -> Script:
    """Each tick, one of the felt states at random (seeded by the skill's name): the object stays in
    the hand but settle counters reset and thresholds are crossed back and forth."""
    rng = np.random.default_rng(zlib.crc32(skill.encode()))
    names = list(FELT)
    return lambda tick, t: felt(names[rng.integers(len(names))])


SCRIPTS: dict[str, Callable[[str], Script]] = {"held": held, "rocking": rocking, "jitter": jitter}


class NotRun(AssertionError):
    """A check that could not run because the skill cannot be made from the params given."""


class ContractBroken(AssertionError):
    """A check found the skill breaking the contract: what is wrong, then what to fix."""

    def __init__(self, problems: str | Iterable[str], fix: str):
        self.problems, self.fix = [problems] if isinstance(problems, str) else list(problems), fix
        super().__init__("; ".join(self.problems) + f" (fix: {fix})")


def _require(problems: list[str], fix: str) -> None:
    if problems:
        raise ContractBroken(problems, fix)


# ---- making the skill ----------------------------------------------------------------------------
def _resolve(cls: type[Skill], params: Params) -> dict[str, Any]:
    """The skill's resolved params; NotRun when they do not resolve (`defaults_validate` says why)."""
    try:
        return cls.resolve_params(dict(params or {}))
    except (KeyError, ValueError):
        raise NotRun(f"not run: {cls.NAME} cannot be made from the params given (see defaults_validate)") from None


def _unmakeable(cls: type[Skill], params: Params) -> tuple[str, str] | None:
    """Why the skill cannot be made from its defaults and `params`, and the call that fixes it."""
    given = dict(params or {})
    try:
        cls.resolve_params(given)
    except KeyError as exc:
        return (f"params names {exc.args[0]!r}, which {cls.NAME} does not declare",
                f"give values only for its params ({', '.join(map(repr, cls.PARAMS))})")
    except ValueError as exc:
        missing = [k for k, d in cls.PARAMS.items() if d.required and k not in given]
        unset = [k for k, d in cls.PARAMS.items() if d.default is None and k not in given]
        values = ", ".join(f"{k!r}: ..." for k in missing) or "..."
        some = f", with values for some of {', '.join(map(repr, unset))}" if unset and not missing else ""
        made_from = f"params={given!r}" if given else "its defaults"
        call = f"check_skill({cls.__name__}, params={{{values}}}){some}"
        return f"it cannot be made from {made_from}: {exc}", f"pass values for the params it cannot do without: {call}"
    return None


@contextmanager
def _in_the_skill_table(cls: type[Skill]) -> Iterator[None]:
    """`cls` under its NAME in the skill table while a tree is loaded, as registering it would; the
    table as it was afterwards. Plug-ins are loaded first, so none is lost when `cls` is taken out."""
    load_plugins()
    before = SKILLS.get(cls.NAME)
    SKILLS[cls.NAME] = cls
    try:
        yield
    finally:
        if before is None:
            del SKILLS[cls.NAME]
        else:
            SKILLS[cls.NAME] = before


def tree_text(skill: str, params: Mapping[str, Any]) -> str:
    """A tree with the skill alone under a sequence (node path `main/s`, on the last line), params
    written as YAML flow (JSON)."""
    return (f"version: 1\nname: contract\ncell: {{tick_hz: {TICK_HZ}}}\nroot:\n  sequence: main\n"
            f"  memory: true\n  children:\n    - {{skill: {skill}, name: s, params: {json.dumps(dict(params))}}}\n")


SKILL_LINE = tree_text("s", {}).count("\n")  # the line of the skill node in `tree_text`


def _harness(cls: type[Skill], params: Params, script: Script) -> TreeHarness:
    """The skill on the mocked cell (an object between the fingers), the task on the blackboard and
    perception from `script`."""
    cell = mock_cell(TICK_HZ, gripper_width=0.06, object_width=0.04)
    with _in_the_skill_table(cls):
        h = TreeHarness.from_text(tree_text(cls.NAME, params or {}), cell=cell, name=TREE_FILE)
    h.set(keys.ELEMENT, copy.deepcopy(ELEMENT))
    h.set(keys.PLATES, copy.deepcopy(PLATES))
    return h.script(script)


# ---- the checks ----------------------------------------------------------------------------------
def defaults_validate(cls: type[Skill], params: Params) -> None:
    """Every param described, every default passing its own declaration, the skill made from its
    defaults and `params`."""
    problems = [f"param {k!r} has no description" for k, d in cls.PARAMS.items() if not d.doc]
    for key, decl in cls.PARAMS.items():
        if decl.required or decl.default is None:
            continue
        try:
            if decl.check(decl.default) != decl.default:
                problems.append(f"param {key!r}: its default {decl.default!r} changes when checked")
        except ValueError as exc:
            problems.append(f"param {key!r}: its default fails its own declaration: {exc}")
    fixes = ["describe every Param and give it a default of its own type and range"] if problems else []
    unmakeable = _unmakeable(cls, params)
    if unmakeable:
        problems.append(unmakeable[0])
        fixes.append(unmakeable[1])
    elif set(cls.resolve_params(dict(params or {}))) != set(cls.PARAMS):
        problems.append("resolve_params does not give exactly the declared params")
        fixes.append("leave resolve_params to Skill (cross-param rules go in validate)")
    _require(problems, "; ".join(fixes))


def invalid_values(decl: Param) -> list[tuple[str, Any]]:
    """(what is wrong, value) for every way a value can break the declaration."""
    bad: list[tuple[str, Any]] = [("wrong type", 1.5 if decl.type == "str" else "text")]
    if decl.type == "vector":
        bad.append(("wrong length", [0.0] * ((decl.length or 3) + 1)))
    n = (decl.length or 1) if decl.type == "vector" else None
    for bound, step, what in ((decl.min, -1, "below min"), (decl.max, 1, "above max")):
        if bound is not None and decl.type in ("float", "int", "vector"):
            value = int(bound) + step if decl.type == "int" else bound + step
            bad.append((what, [float(value)] * n if n else value))
    if decl.choices:
        bad.append(("not a choice", "no_such_choice"))
    return bad


def invalid_values_refused(cls: type[Skill], params: Params) -> None:
    """Each invalid value refused naming the param, and in a tree with an error located at the
    file, the skill's line and its node path."""
    _resolve(cls, params)
    problems = []
    for key, decl in cls.PARAMS.items():
        for what, value in invalid_values(decl):
            given = {**(params or {}), key: value}
            try:
                cls.resolve_params(given)
                problems.append(f"{key} {what} {value!r}: accepted")
            except ValueError as exc:
                if repr(key) not in str(exc):
                    problems.append(f"{key} {what}: the message does not name the param: {exc}")
            errors: Sequence[FvtreeError] = []
            try:
                with _in_the_skill_table(cls):
                    load_tree(text=tree_text(cls.NAME, given), name=TREE_FILE)
            except TreeErrors as caught:
                errors = caught.errors
            if not any(e.file == TREE_FILE and e.line == SKILL_LINE and e.field == SKILL_PATH and repr(key) in e.message
                       for e in errors):
                found = "; ".join(map(str, errors)) or "the tree loaded"
                problems.append(f"{key} {what}: no error located at {TREE_FILE}:{SKILL_LINE} {SKILL_PATH}: {found}")
    _require(problems, "declare each param's type, length, min, max and choices in its Param; a value "
                       "validate() refuses raises ValueError naming the param (\"param 'x': ...\")")


def _recorded(device: SafeArm | SafeGripper) -> list[Command]:
    """The commands a mocked cell's device recorded."""
    if not isinstance(device, RecordingArm | RecordingGripper):
        raise TypeError("the checks run on a mocked cell, whose arm and gripper record their commands")
    return device.commands


def halting_stops_the_devices(cls: type[Skill], params: Params) -> None:
    """Halted by its parent, as a selector or a timeout does, only the skill's own `terminate` runs
    (`TreeHarness.halt` would stop the devices itself, hiding a skill that does not)."""
    _resolve(cls, params)
    h = _harness(cls, params, lambda tick, t: felt("slipping"))
    h.cell.estop = cls.RUNS_UNTIL_HALTED  # what keeps estop_guard running
    for _ in range(HALT_WITHIN):
        h.tick()
        if h.status(SKILL_PATH) != "RUNNING":
            raise ContractBroken(f"it ended ({h.status(SKILL_PATH)}: {h.feedback(SKILL_PATH)!r}) before "
                                 "commanding anything, so halting it could not be checked",
                                 "keep running while the arm or the gripper moves under a slipping grasp")
        if _recorded(h.arm) or _recorded(h.gripper):
            break
    else:
        raise ContractBroken(f"it commanded nothing in {HALT_WITHIN} ticks",
                             "command the arm or the gripper within its first ticks")
    h.tree.root.stop(Status.INVALID)
    h.settle()  # a stopped arm brakes before it stands
    problems = []
    if h.status(SKILL_PATH) != "INVALID":
        problems.append(f"halted, it is {h.status(SKILL_PATH)}, not INVALID")
    moving = [name for name, device in (("arm", h.arm), ("gripper", h.gripper)) if device.is_moving()]
    if moving:
        problems.append(f"halted, the {' and the '.join(moving)} {'are' if len(moving) > 1 else 'is'} still moving")
    last = {name: [c.name for c in _recorded(device)[-1:]] for name, device in (("arm", h.arm), ("gripper", h.gripper))}
    if last != {"arm": ["stop"], "gripper": ["stop"]}:
        problems.append(f"the last commands are {last}, not stops")
    _require(problems, "leave halting to Skill.terminate (it stops the arm and the gripper); an override "
                       "calls super().terminate(new_status)")


def reads_have_writers(cls: type[Skill], params: Params) -> None:
    """Every key read (but those read with a fallback) written by perception, the task or a skill."""
    load_plugins()
    written = known_blackboard_keys() | set(cls.WRITES)
    problems = []
    unwritten = sorted(set(cls.READS) - set(cls.OPTIONAL_READS) - written)
    if unwritten:
        problems.append(f"it reads keys nothing writes: {unwritten}")
    for what in ("READS", "WRITES"):
        declared = getattr(cls, what)
        if len(set(declared)) != len(declared):
            problems.append(f"{what} names a key twice: {sorted({k for k in declared if declared.count(k) > 1})}")
    stray = sorted(set(cls.OPTIONAL_READS) - set(cls.READS))
    if stray:
        problems.append(f"OPTIONAL_READS names keys not in READS: {stray}")
    _require(problems, "read keys that perception (/fv/*, /robot/*, /gripper/*), the task (/task/element, "
                       "/task/plates) or a skill's WRITES provide, or list a key read with a fallback in "
                       "OPTIONAL_READS; declare each key once")


# Device methods that read robot state; skills call the snapshot helpers of the same names on `self`.
DEVICE_READS = frozenset({"pose", "width", "is_moving", "fault", "object_detected", "tcp_wrench", "tcp_speed"})


def device_reads(source: str) -> list[str]:
    """Calls in `source` that read robot state from a device (`self.cell.arm.pose()`, `arm.fault()`),
    as 'line N: call'; calls on `self` or `skill` (the snapshot helpers) are not."""
    return [f"line {node.lineno}: {ast.unparse(node)}" for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
            and node.func.attr in DEVICE_READS
            and not (isinstance(node.func.value, ast.Name) and node.func.value.id in ("self", "skill"))]


def reads_no_device_state(cls: type[Skill], params: Params) -> None:
    """A read on a device in the middle of a tick may see a newer state than the snapshot the other
    skills of that tick see; the snapshot helpers (`self.pose()`, ...) are the way."""
    module = sys.modules.get(cls.__module__)
    try:
        if module is None:
            raise TypeError("it is not imported")
        source, where = inspect.getsource(module), inspect.getsourcefile(module)
    except (OSError, TypeError) as exc:
        raise ContractBroken(f"the source of its module {cls.__module__} cannot be read ({exc})",
                             "define the skill in a module of its own, in a file") from None
    _require([f"{where} reads the devices at {call}" for call in device_reads(source)],
             "read this tick's snapshot: self.pose(), self.arm_fault(), self.arm_moving(), "
             "self.gripper_width(), self.gripper_object(), ... (each with its key in READS)")


def ends_by_itself(script: str) -> Callable[[type[Skill], Params], None]:
    """The check that the skill ends within MAX_TICKS under the perception `script`, the arm still."""

    def check(cls: type[Skill], params: Params) -> None:
        resolved = _resolve(cls, params)
        if cls.runs_until_halted(resolved):
            _require([] if cls.RUNS_UNTIL_HALTED else ["it runs until halted with these params"],
                     "set RUNS_UNTIL_HALTED = True, or give it a bound at its defaults")
            return
        h = _harness(cls, params, SCRIPTS[script](cls.NAME))
        try:
            status = h.run_until_done(MAX_TICKS)
        except AssertionError:
            said = h.feedback(SKILL_PATH)
            raise ContractBroken(f"still RUNNING after {MAX_TICKS / TICK_HZ:.0f} s of cell time under the {script!r} "
                                 "script" + (f" (last feedback: {said!r})" if said else ""),
                                 "end within a bound (a max_time param from time_limit(), a travel limit, "
                                 "each move's timeout) or set RUNS_UNTIL_HALTED = True") from None
        _require([] if not h.arm.is_moving() or h.arm.fault() else [f"it ended ({status.name}) with the arm moving"],
                 "stop the motion you commanded before ending (ProgramSkill.move waits for it)")

    check.__doc__ = f"Ends by itself within a bound under the {script!r} perception script. {SCRIPTS[script].__doc__}"
    return check


def documented(cls: type[Skill], params: Params) -> None:
    """Registered under its NAME, with a SUMMARY, in `fvtree skills`' catalogue and the tree schema."""
    load_plugins()
    holder = SKILLS.get(cls.NAME)
    if holder is None:
        raise ContractBroken(f"no skill is registered under {cls.NAME!r}",
                             "decorate the class with @register (this project) or add an entry point in group "
                             "'fvtree.skills' and install the package (a plug-in)")
    if holder is not cls:
        raise ContractBroken(f"{cls.NAME!r} is taken by {holder.__module__}.{holder.__qualname__} of package "
                             f"{SKILL_PACKAGES.get(cls.NAME)}", "give the skill a NAME of its own")
    problems = [] if cls.SUMMARY else ["it has no SUMMARY (the catalogue's line)"]
    if cls.NAME not in describe_skills():
        problems.append("`fvtree skills` does not list it")
    variants = tree_schema()["$defs"]["node"]["oneOf"]
    if not any(v["properties"].get("skill", {}).get("const") == cls.NAME for v in variants):
        problems.append("the tree JSON Schema (`fvtree schema`) has no variant for it")
    _require(problems, "set SUMMARY to one line saying what the skill does")


CHECKS: dict[str, Callable[[type[Skill], Params], None]] = {
    "defaults_validate": defaults_validate,
    "invalid_values_refused": invalid_values_refused,
    "halting_stops_the_devices": halting_stops_the_devices,
    "reads_have_writers": reads_have_writers,
    "reads_no_device_state": reads_no_device_state,
    **{f"ends_by_itself-{script}": ends_by_itself(script) for script in SCRIPTS},
    "documented": documented,
}


# ---- running them --------------------------------------------------------------------------------
@dataclass(frozen=True)
class SkillCheck:
    """One check of the contract bound to a skill and its params: call it to run it (AssertionError
    when the skill breaks it)."""

    name: str
    skill: type[Skill]
    params: Params
    run: Callable[[type[Skill], Params], None]

    def __call__(self) -> None:
        self.run(self.skill, self.params)

    def __str__(self) -> str:
        return f"{self.skill.NAME}-{self.name}"


def skill_checks(cls: type[Skill], params: Params = None) -> Iterator[SkillCheck]:
    """The checks of the contract on the Skill class `cls`, one named callable each; `params` gives
    values for the params the skill cannot do without (`{"offset": [0, 0, 0.02]}` for move_to)."""
    if not (isinstance(cls, type) and issubclass(cls, Skill) and cls.NAME):
        raise TypeError(f"the skill contract checks a Skill class with a NAME, not {cls!r}")
    for name, run in CHECKS.items():
        yield SkillCheck(name, cls, params, run)


def check_skill(cls: type[Skill], params: Params = None) -> None:
    """Run every check of the contract on the Skill class `cls`; one AssertionError lists every
    broken check with what to fix, or the exception the skill raised in it (and the checks that
    could not run)."""
    broken, not_run = [], []
    for check in skill_checks(cls, params):
        try:
            check()
        except NotRun:
            not_run.append(check.name)
        except AssertionError as exc:
            broken.append(f"- {check.name}: {exc}")
        except Exception as exc:  # noqa: BLE001 - a skill that raises breaks the check; the others still run
            frame = traceback.extract_tb(exc.__traceback__)[-1]
            broken.append(f"- {check.name}: raised {type(exc).__name__}: {exc} ({frame.filename}:{frame.lineno})")
    if broken:
        head = f"{cls.NAME} ({cls.__module__}.{cls.__qualname__}) breaks {len(broken)} of the {len(CHECKS)} checks"
        lines = [head + " of the skill contract:", *broken]
        if not_run:
            lines.append(f"not run, since it cannot be made (see defaults_validate): {', '.join(not_run)}")
        raise AssertionError("\n".join(lines))


def parametrize_with_skill_checks(skills: Iterable[type[Skill]],
                                  params: Mapping[str, Mapping[str, Any]] | None = None) -> pytest.MarkDecorator:
    """A `pytest.mark.parametrize` over every check of every skill in `skills`, as argument `check`
    (ids `NAME-check`); `params` maps a skill's NAME to the values it cannot do without.

        @parametrize_with_skill_checks([Pinch])
        def test_contract(check):
            check()
    """
    import pytest  # only here: the checks themselves run without pytest

    checks = [check for cls in skills for check in skill_checks(cls, (params or {}).get(cls.NAME))]
    return pytest.mark.parametrize("check", checks, ids=[str(check) for check in checks])
