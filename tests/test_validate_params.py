"""What `fvtree validate` checks of params beyond their declared ranges: against the cell (`fvtree validate
TREE [--cell CELL]`: a skill param bound to a device range, `Param.device`, within the cell's arm and
gripper ranges, read from its cell file without building it; the error names the tree's file, line and
field, the range and where the cell file sets it), and the units of subtree params passed on."""

from __future__ import annotations

from pathlib import Path

import pytest

from assembly.cli import main
from assembly.errors import TreeErrors
from assembly.language.reader import load_tree
from behaviours.skill_kit.base import DEVICE_RANGES, Param
from behaviours.skill_kit.registry import SKILLS
from drivers.cell_file import CELLS_DIR
from drivers.device_ranges import device_ranges

TREE = """version: 1
name: t
cell: {scene: hold}
subtrees:
  go:
    params: {speed: {type: float, unit: m/s}}
    root: {skill: move_to, name: move, params: {offset: [0, 0, 0.1], speed: $speed}}
root:
  sequence: s
  memory: true
  children:
    - skill: gentle_grasp
      name: grasp
      params:
        force: FORCE
    - {subtree: go, name: up, params: {speed: SPEED}}
"""


def tree(tmp_path: Path, force: float = 40.0, speed: float = 0.1) -> Path:
    path = tmp_path / "t.yaml"
    path.write_text(TREE.replace("FORCE", str(force)).replace("SPEED", str(speed)))
    return path


def errors(path: Path, cell: str) -> list:
    with pytest.raises(TreeErrors) as caught:
        load_tree(path, cell=cell)
    return caught.value.errors


def test_a_grasp_force_beyond_the_grippers_range_is_refused_at_its_line(tmp_path):
    (error,) = errors(tree(tmp_path, force=500.0), "sim")
    assert (error.file, error.line, error.path) == (str(tmp_path / "t.yaml"), 15, "s/grasp")
    assert error.message.startswith("param 'force' = 500 N is outside the gripper force range of cell sim, [0, 235] N")
    assert "refuses" in error.hint and "235 N" in error.hint
    assert load_tree(tree(tmp_path, force=235.0), cell="sim")  # the end of the range is inside it


def test_a_speed_passed_through_a_subtree_is_checked_against_the_cells_safety_file(tmp_path):
    path = tree(tmp_path, speed=0.2)
    assert load_tree(path, cell="sim")  # sim.yaml: max_speed 0.25
    (error,) = errors(path, "ur_robotiq")  # ur_robotiq.yaml: max_speed 0.15
    assert error.path == "s/up/move" and "ur_robotiq.yaml:" in error.message
    assert error.message.endswith("[0, 0.15] m/s, from ur_robotiq.yaml:37 safety.max_speed")


def test_a_cell_files_own_limits_are_the_ranges(tmp_path):
    cell = tmp_path / "slow.yaml"
    cell.write_text((CELLS_DIR / "sim.yaml").read_text().replace("max_speed: 0.25", "max_speed: 0.05")
                    .replace("max_width: 0.085", "max_width: 0.05"))
    ranges = device_ranges(str(cell))
    assert (ranges["arm_speed"].high, ranges["gripper_width"].high) == (0.05, 0.05)
    assert ranges["arm_speed"].source == f"{cell}:8 safety.max_speed"
    assert "sets no safety.max_angular_speed" in ranges["arm_angular_speed"].source
    (error,) = errors(tree(tmp_path), str(cell))
    assert "0.1 m/s is outside the TCP speed range" in error.message and "caps" in error.hint


def test_the_cli_checks_for_the_named_cell_and_still_checks_cell_files_whole(tmp_path, capsys):
    path = tree(tmp_path, speed=0.2)
    assert main(["validate", str(path)]) == 0
    assert "for cell sim" in capsys.readouterr().out
    assert main(["validate", str(path), "--cell", "ur_robotiq"]) == 2
    out, err = capsys.readouterr()
    assert "ur_robotiq: ok" in out and "safety.max_speed" in err
    assert main(["validate", "--cell", "sim"]) == 0  # a cell alone, as before
    assert main(["validate", str(CELLS_DIR / "emulated.yaml")]) == 0  # a cell file among the files
    assert "cell 'emulated" in capsys.readouterr().out
    assert main(["validate"]) == 2
    assert "nothing to validate" in capsys.readouterr().err


def test_run_checks_the_tree_against_the_cell_it_runs_on_before_building_it(tmp_path, capsys):
    """`fvtree run` applies validate's device-range check for the cell it runs on: the tree is
    refused at its line, exit 2, before any device is created (no run directory either)."""
    runs = tmp_path / "runs"
    assert main(["run", str(tree(tmp_path, force=500.0)), "--runs-dir", str(runs)]) == 2
    assert "t.yaml:15: s/grasp: param 'force' = 500 N is outside the gripper force range of cell sim" \
        in capsys.readouterr().err
    assert not runs.exists()


def test_every_device_param_names_a_known_range_in_its_unit():
    units = {"gripper_force": "N", "gripper_width": "m", "arm_speed": "m/s", "arm_angular_speed": "rad/s",
             "arm_force": "N"}
    assert set(units) == set(DEVICE_RANGES)
    bound = [(name, key, p) for name, cls in SKILLS.items() for key, p in cls.PARAMS.items() if p.device]
    assert len(bound) >= 15
    for name, key, p in bound:
        assert p.unit == units[p.device], f"{name}.{key}"
    with pytest.raises(ValueError, match="device range 'gripper_torque'"):
        Param("float", "x", 1.0, "N m", device="gripper_torque")


UNITS = """version: 1
name: u
cell: {scene: hold}
subtrees:
  keep:
    params: {hold_time: {type: float, unit: UNIT, default: 2000}}
    root: {skill: hold, name: hold, params: {duration: $hold_time}}
  outer:
    params: {wait: {type: float, unit: ms, default: 500}}
    root: {subtree: keep, name: inner, params: {hold_time: $wait}}
root:
  sequence: s
  memory: true
  children:
    - {skill: gentle_grasp, name: grasp}
    - {subtree: ROOT, name: k}
"""


def test_a_subtree_param_in_ms_passed_into_a_param_in_s_is_refused_with_the_value_in_s():
    """Units are checked, never converted: 2000 ms given to a hold's `duration` (s) would hold 2000 s."""
    with pytest.raises(TreeErrors) as caught:
        load_tree(text=UNITS.replace("UNIT", "ms").replace("ROOT", "keep"), name="u.yaml")
    (error,) = caught.value.errors
    assert (error.line, error.path) == (7, "s/k/hold")
    assert error.message == "param 'duration' takes s, but $hold_time is declared in ms by subtree 'keep'"
    assert error.hint == "declare $hold_time with unit 's' and give it 2 (2000 ms = 2 s)"
    assert load_tree(text=UNITS.replace("UNIT", "s").replace("ROOT", "keep").replace("2000", "2.0"), name="u.yaml")


def test_units_are_checked_from_subtree_to_subtree():
    with pytest.raises(TreeErrors) as caught:
        load_tree(text=UNITS.replace("UNIT", "s").replace("ROOT", "outer"), name="u.yaml")
    (error,) = caught.value.errors
    assert (error.line, error.path) == (10, "s/k/inner")
    assert "param 'hold_time' takes s, but $wait is declared in ms by subtree 'outer'" in error.message
    assert "give it 0.5 (500 ms = 0.5 s)" in error.hint
