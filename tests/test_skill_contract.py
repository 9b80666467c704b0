"""The skill contract (`assembly.testing.check_skill`) on every registered skill, one case per
skill and check: its declared params validate and refuse bad values with a located error, it
stops the arm and the gripper when halted, every key it reads has a writer, it reads robot state
from the tick's snapshot, it ends by itself within a bound (or declares that it runs until halted)
and it is documented. A new skill gets all of these checks by being registered. Here too, what
only this project asks: a row in README.md's skill table and a demo tree under trees/; and the
contract's own report on a skill that breaks it."""

from __future__ import annotations

import re
from pathlib import Path
from typing import ClassVar

import pytest
from py_trees.blackboard import ActivityStream, Blackboard
from py_trees.common import Status

from assembly.run.perception_stage import clear_blackboard
from assembly.testing import check_skill, parametrize_with_skill_checks, skill_checks
from assembly.testing.skill_checks import CHECKS, device_reads
from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, Skill
from behaviours.skill_kit.registry import SKILLS

ROOT = Path(__file__).resolve().parents[1]
NAMES = sorted(SKILLS)

# Params a skill cannot do without (no usable default).
NEEDED = {"move_to": {"offset": [0.0, 0.0, 0.02]}}


@parametrize_with_skill_checks([SKILLS[name] for name in NAMES], params=NEEDED)
def test_the_contract(check):
    check()


@pytest.mark.parametrize("module", sorted({p.name for p in (ROOT / "behaviours").glob("*.py")}
                                          - {f"{cls.__module__.rpartition('.')[2]}.py" for cls in SKILLS.values()}))
def test_modules_without_a_skill_read_no_device_state(module):
    """The contract scans each skill's module; the other modules of behaviours/ get the same scan."""
    calls = device_reads((ROOT / "behaviours" / module).read_text())
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


# ---- what only this project asks: documented in the README and demonstrated under trees/ ----------
SKILL_TABLE = "\n".join(line for line in (ROOT / "README.md").read_text().splitlines() if line.startswith("| `"))


def uses(tree: Path, name: str) -> bool:
    try:
        return re.search(rf"skill: {name}\b", tree.read_text()) is not None
    except FileNotFoundError:  # deleted since it was listed
        return False


@pytest.mark.parametrize("name", NAMES)
def test_in_the_readme_and_demonstrated(name):
    assert re.search(rf"`{name}`", SKILL_TABLE), f"{name} is missing from README.md's skill table"
    assert any(uses(tree, name) for tree in (ROOT / "trees").rglob("*.yaml")), f"no tree under trees/ uses {name}"


def test_the_skills_are_skills():
    assert all(issubclass(cls, Skill) and cls.NAME == name and cls.SUMMARY for name, cls in SKILLS.items())


# ---- the contract's report -------------------------------------------------------------------------
class Careless(ProgramSkill):
    """Closes the fingers and never stops: breaks every check but the refusal of invalid values."""

    NAME = "careless"
    PARAMS: ClassVar[dict[str, Param]] = {"speed": Param("float", "", 0.01, "m/s", min=0.001)}
    READS = (keys.GRIPPER_WIDTH, "/task/nobody_writes", keys.GRIPPER_WIDTH)

    def program(self):
        self.cell.gripper.move(0.0, speed=self.p.speed, force=10.0)
        while self.cell.gripper.width() >= 0.0:
            yield

    def terminate(self, new_status: Status) -> None:
        """Forgets `super().terminate`: the fingers go on closing."""


def test_a_broken_skill_is_reported_check_by_check_with_what_to_fix():
    with pytest.raises(AssertionError) as caught:
        check_skill(Careless)
    report = str(caught.value)
    broken = re.findall(r"^- (\S+):", report, re.MULTILINE)
    assert broken == [name for name in CHECKS if name != "invalid_values_refused"], report
    for says in ("param 'speed' has no description", "nothing writes: ['/task/nobody_writes']",
                 "READS names a key twice: ['/gripper/width']", "self.cell.gripper.width()",
                 "the last commands are {'arm': [], 'gripper': ['move']}", "super().terminate(new_status)",
                 "still RUNNING after 300 s", "no skill is registered under 'careless'"):
        assert says in report, f"{says!r} not in:\n{report}"
    assert "careless" not in SKILLS  # put in the table while its trees were loaded, then taken out


class Raising(ProgramSkill):
    """Raises on its first tick."""

    NAME = "raising"
    SUMMARY = "raises"

    def program(self):
        raise RuntimeError("out of cheese")
        yield


def test_a_skill_that_raises_breaks_the_checks_that_tick_it_and_the_others_still_run():
    with pytest.raises(AssertionError) as caught:
        check_skill(Raising)
    report = str(caught.value)
    assert "- halting_stops_the_devices: raised RuntimeError: out of cheese (" in report, report
    assert re.findall(r"^- (\S+): raised RuntimeError", report, re.MULTILINE) == [
        "halting_stops_the_devices", "ends_by_itself-held", "ends_by_itself-rocking", "ends_by_itself-jitter"], report


def test_a_skill_that_cannot_be_made_from_its_defaults_is_told_which_params_to_give():
    checks = {check.name: check for check in skill_checks(SKILLS["move_to"])}
    with pytest.raises(AssertionError, match=r"give exactly one of 'pose' or 'offset'.*check_skill\(MoveTo, params="):
        checks["defaults_validate"]()
    with pytest.raises(AssertionError, match="not run: move_to cannot be made"):
        checks["halting_stops_the_devices"]()
    with pytest.raises(TypeError, match="a Skill class with a NAME"):
        next(skill_checks(Skill))
