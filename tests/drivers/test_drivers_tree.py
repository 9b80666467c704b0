"""Trees run unchanged on the emulated real cell (UR + Robotiq emulators, scripted perception):
a move completes, and an injected protective stop fails the tree safe with the arm stopped."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from drivers_testkit import Emulator, emulating, next_host, tolerant_of_load, wait_until

from assembly.testing import TreeHarness, touch
from drivers.cell_builders import load_cell
from drivers.cell_file import CELLS_DIR

TREE = """
version: 1
name: emulated_moves
cell: {tick_hz: 30}
root:
  sequence: moves
  memory: true
  children:
    - {skill: move_to, name: over, params: {pose: [0.05, -0.45, 0.35, 3.141593, 0.0, 0.0], speed: 0.2}}
    - {skill: move_to, name: down, params: {offset: [0.0, 0.0, -0.1], speed: 0.05}}
"""


@pytest.fixture
def cell(tmp_path):
    """The emulated cell without cameras (perception is scripted), on fresh loopback addresses,
    tolerant of a loaded machine."""
    data = tolerant_of_load(yaml.safe_load((CELLS_DIR / "emulated.yaml").read_text()))
    data["arm"]["host"], data["gripper"]["host"] = next_host(), next_host()
    data.pop("cameras")
    data["perception"] = {"source": "none"}
    path = tmp_path / "emulated.yaml"
    path.write_text(yaml.safe_dump(data))
    with emulating(path) as procs:
        the_cell = load_cell(str(path), 30.0, "assembly", {})
        the_cell.ur = Emulator(procs[0], data["arm"]["host"], 30999)
        yield the_cell
        the_cell.close()


def no_contact(tick, t):
    return {f: touch(f, stamp=t) for f in ("left", "right")}


def test_a_tree_of_moves_runs_to_success_on_the_emulated_cell(cell):
    h = TreeHarness.from_text(TREE, cell=cell).script(no_contact)
    assert h.run_until_done(max_ticks=300).name == "SUCCESS"
    expected = [0.05, -0.45, 0.25, 3.141593, 0.0, 0.0]
    assert np.allclose(cell.ur.state()["pose"], expected, atol=1e-6)
    assert cell.arm.fault() is None


def test_protective_stop_mid_move_fails_the_tree_with_the_arm_stopped(cell):
    h = TreeHarness.from_text(TREE, cell=cell).script(no_contact)
    h.tick(5)
    assert cell.arm.is_moving()
    cell.ur.call("protective_stop")
    status = h.run_until_done(max_ticks=60)
    assert status.name == "FAILURE"
    assert "protective stop" in cell.arm.fault()
    assert wait_until(lambda: cell.ur.state()["velocity"] == [0.0] * 6, 10.0)
    assert cell.ur.state()["protective_stopped"]  # nobody unlocked it
