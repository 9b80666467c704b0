"""Faults injected on the emulated cell (the real ur_rtde and pymodbus clients against the UR and
Robotiq emulators on loopback, perception scripted): each one is caught by the cell supervisor,
which trips arm and gripper and ends the run with status FAULT naming the cause and the node; the
gripper overcurrent is caught within 0.1 s of cell time (counted in ticks: a loaded machine ticks
the wall clock late). The timeouts that measure scheduling are raised (`tolerant_of_load`), so that
only the injected fault stops the cell."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent / "drivers"))
from drivers_testkit import DEADLINE, WALL_SLACK, Emulator, emulating, next_host, tolerant_of_load, wait_until

from assembly.language.build import build
from assembly.language.reader import load_tree
from assembly.run.loop import Runner
from assembly.run.supervisor import Supervision
from assembly.testing import touch
from drivers.cell_builders import load_cell
from drivers.cell_file import CELLS_DIR

TREE = """version: 1
name: carry
cell: {tick_hz: 30}
root:
  sequence: main
  memory: true
  children:
    - {skill: move_to, name: carry, params: {pose: [0.3, -0.4, 0.3, 3.141593, 0.0, 0.0], speed: 0.05}}
"""
TICK_HZ = 30
INJECT_AT_TICK = 20  # the arm is well under way (the move takes about 10 s)

# backdoor target (ur | robotiq), its command, and what the fault message says
FAULTS = {
    "gripper overcurrent": ("robotiq", "fault 0x0E", "gripper fault"),
    "protective stop": ("ur", "protective_stop", "arm fault"),
    "e-stop": ("ur", "estop", "arm fault"),
    "dropped link": ("ur", "drop 30", "arm fault"),
}


@pytest.fixture
def cell(tmp_path):
    """The emulated cell without cameras on fresh loopback addresses; its emulators by name."""
    data = tolerant_of_load(yaml.safe_load((CELLS_DIR / "emulated.yaml").read_text()))
    data["arm"]["host"], data["gripper"]["host"] = next_host(), next_host()
    data.pop("cameras")
    data["perception"] = {"source": "none"}
    path = tmp_path / "emulated.yaml"
    path.write_text(yaml.safe_dump(data))
    with emulating(path) as procs:
        the_cell = load_cell(str(path), float(TICK_HZ), "assembly", {})
        the_cell.emulators = {"ur": Emulator(procs[0], data["arm"]["host"], 30999),
                              "robotiq": Emulator(procs[1], data["gripper"]["host"], 30998)}
        yield the_cell
        the_cell.close()


@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_an_injected_fault_stops_arm_and_gripper_and_faults_the_run(cell, fault):
    target, command, cause = FAULTS[fault]
    injected = {}

    def inject(tree):  # after a tick, while the cell waits for the next period
        if tree.count == INJECT_AT_TICK:
            cell.emulators[target].call(command)
            injected["t"] = cell.clock.now()
        if runner.supervisor.tripped_at is not None:
            injected.setdefault("tripped at tick", tree.count)

    supervision = Supervision(perception_stale_after=WALL_SLACK)  # a slow tick must not trip it before the fault
    runner = Runner(build(load_tree(text=TREE, name="carry.yaml")), cell, supervision=supervision, max_time=60.0,
                    sense=lambda: {f: touch(f, stamp=cell.clock.now()) for f in ("left", "right")})
    runner.behaviour_tree.add_post_tick_handler(inject)
    runner.setup()
    result = runner.run()
    assert result.status == "FAULT" and result.where == "main/carry", result.message
    assert result.message.startswith(cause) and result.message.endswith("(during main/carry)")
    assert cell.arm.fault() and cell.gripper.fault()
    if fault == "gripper overcurrent":  # within 0.1 s of cell time: 3 ticks at 30 Hz
        assert injected["tripped at tick"] - INJECT_AT_TICK <= round(0.1 * TICK_HZ), injected
        print(f"gripper overcurrent: arm and gripper tripped {runner.supervisor.tripped_at - injected['t']:.3f} s "
              "of cell time after the injection")
    if fault != "dropped link":  # a dropped link leaves nobody to ask
        ur = cell.emulators["ur"]
        assert wait_until(lambda: ur.state()["velocity"] == [0.0] * 6, DEADLINE)
