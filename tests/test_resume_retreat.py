"""A run stopped while the arm backs out of an element it just placed finishes that way out first
when resumed, from where the arm stands, and only then goes on (the next element, or home): a
straight move home from between the open fingers could sweep them through the element. Before,
the resumed session's first move went straight home."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from assembly.errors import TreeError
from assembly.run.options import RunOptions
from assembly.run.session import Run, run_tree
from behaviours.skill_kit.retreat import remaining_path, retreat_path

ROOT = Path(__file__).resolve().parents[1]
ASSEMBLY = str(ROOT / "trees" / "assembly.yaml")
QUIET = {"quiet": True, "plots": False, "record": False}
HOME = [0.0, 0.0, 0.5, 3.141593, 0.0, 0.0]  # trees/assembly.yaml's last move


def lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_the_rest_of_a_way_out_continues_from_where_the_arm_stopped():
    release = np.array([0.1, 0.4, 0.3, np.pi, 0.0, 0.0])
    path = retreat_path(release, [0.0, -0.2, 0.0], 0.1)
    assert np.allclose(path[0][:3], [0.1, 0.2, 0.3]) and np.allclose(path[1][:3], [0.1, 0.2, 0.4])
    on_level_leg = release + [0, -0.05, 0, 0, 0, 0]
    assert [p.tolist() for p in remaining_path(path, on_level_leg)] == [p.tolist() for p in path]
    on_lifting_leg = path[0] + [0, 0, 0.04, 0, 0, 0]
    assert [p.tolist() for p in remaining_path(path, on_lifting_leg)] == [path[1].tolist()]


@pytest.fixture(scope="module")
def full_run(tmp_path_factory) -> Path:
    """The whole assembly, to learn when E2's way out runs."""
    return Path(run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path_factory.mktemp("full"), **QUIET)).run_dir)


def place_ended(run_dir: Path) -> float:
    """Cell time at which the last element's place_element (its release, then the way out) ended."""
    return [t for t in lines(run_dir / "transitions.jsonl")
            if t["node"].endswith("/prop/place") and t["to"] == "SUCCESS"][-1]["t"]


def resumed_moves(runs: Path) -> tuple[list[list[float]], object]:
    """The resumed session's arm targets (move_linear), and its summary."""
    targets: list[list[float]] = []
    with Run(ASSEMBLY, RunOptions(runs_dir=runs, resume="latest", **QUIET)) as run:
        arm = run.cell.arm
        move = arm.move_linear

        def recorded(pose, *args, **kwargs):
            targets.append(np.round(np.asarray(pose, float), 4).tolist())
            return move(pose, *args, **kwargs)
        arm.move_linear = recorded  # type: ignore[method-assign]
        summary = run.finish(run.loop())
    return targets, summary


@pytest.mark.slow
@pytest.mark.parametrize("before_end", [0.5, 2.0], ids=["lifting", "backing_out"])
def test_a_run_stopped_during_the_way_out_finishes_it_before_going_home(full_run, tmp_path, before_end):
    """E-stopped `before_end` s of cell time before E2's place_element ended: on the lifting leg
    (0.5 s) or the level one (2 s). The `placed` record holds the way out; the resumed session
    moves to its end before home, and logs `retreated`. (In simulation the resumed arm starts at
    home, above the backed-out pose: what is left is the lifted pose.)"""
    stopped = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, estop_at=place_ended(full_run) - before_end, **QUIET))
    run_dir = Path(stopped.run_dir)
    assert stopped.status == "ESTOP" and stopped.where.endswith("/prop/place")
    events = lines(run_dir / "events.jsonl")
    placed = [e for e in events if e["event"] == "placed" and e["element"] == "E2"]
    assert len(placed) == 1 and not any(e["event"] == "retreated" and e["element"] == "E2" for e in events)
    way_out = placed[0]["retreat"]["path"]

    targets, summary = resumed_moves(tmp_path)
    assert summary.status == "SUCCESS"
    assert np.allclose(targets[0], way_out[-1], atol=1e-4) and np.allclose(targets[-1], HOME, atol=1e-4)
    session = lines(run_dir / "events.jsonl")[len(events):]
    assert [e["event"] for e in session if e["event"] in ("start", "placing", "retreated", "end")] == \
        ["start", "retreated", "end"]  # nothing built again


@pytest.mark.slow
def test_a_finished_way_out_is_not_driven_again(full_run, tmp_path):
    """Stopped on the way home, after E2's `retreated` record: the resume goes home at once."""
    stopped = run_tree(ASSEMBLY, RunOptions(runs_dir=tmp_path, estop_at=place_ended(full_run) + 0.5, **QUIET))
    assert stopped.status == "ESTOP" and stopped.where.endswith("/home")
    targets, summary = resumed_moves(tmp_path)
    assert summary.status == "SUCCESS" and targets and all(np.allclose(t, HOME, atol=1e-4) for t in targets)


def test_a_way_out_outside_the_cells_box_is_refused(full_run, tmp_path):
    """A hand-edited way out is checked like every pose a resume drives the arm to."""
    run_dir = tmp_path / "runs" / full_run.name
    shutil.copytree(full_run, run_dir)
    events = run_dir / "events.jsonl"
    records = lines(events)
    number = next(i for i, e in enumerate(records, 1) if e["event"] == "placed" and e["element"] == "E2")
    records[number - 1]["retreat"]["path"][-1][2] = -0.5
    events.write_text("".join(json.dumps(r) + "\n" for r in records[:number]))  # stopped before `retreated`
    with pytest.raises(TreeError) as caught:
        Run(ASSEMBLY, RunOptions(runs_dir=tmp_path / "runs", resume="latest", **QUIET)).open()
    assert (caught.value.file, caught.value.line, caught.value.field) == (str(events), number, "retreat.path")
    assert "outside the cell's safety box" in caught.value.message
