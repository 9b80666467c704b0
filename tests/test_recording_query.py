"""Tree statuses read back through Rerun's own query API (a catalog server on 127.0.0.1 serving the
run's recording, queried as a dataframe): by the `change` timeline every status change of the run
is a row, in the transition log's order; by tick, several changes in one tick collapse to one row
(why the `change` timeline exists). The recording `fvtree view` builds for an old run (from its
logs) numbers its changes the same way."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import rerun as rr

from assembly.observe.recorder import CHANGE_TIMELINE
from assembly.observe.replay import recording_from_logs
from assembly.run.options import RunOptions
from assembly.run.perception_stage import clear_blackboard
from assembly.run.session import run_tree

TREES = Path(__file__).resolve().parents[1] / "trees"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """The simulated assembly cut short after placing E1 (80 s of cell time)."""
    clear_blackboard()
    options = RunOptions(runs_dir=tmp_path_factory.mktemp("runs"), plots=False, quiet=True, max_time=80.0)
    return Path(run_tree(str(TREES / "assembly.yaml"), options).run_dir)


def _query(recording: Path, entity: str, index: str) -> list[dict]:
    """The rows of `entity` in Rerun's dataframe of `recording` by the timeline `index`, in its order."""
    with rr.server.Server(host="127.0.0.1", datasets={"run": [str(recording)]}) as server:
        dataset = server.client().get_dataset("run").filter_contents([f"/{entity}"])
        table = dataset.reader(index=index).to_arrow_table().sort_by(index)
    return table.to_pylist()


def _statuses(rows: list[dict]) -> list[tuple[int, str, str]]:
    return [(row["tick"], row["/tree/status:node"][0], row["/tree/status:status"][0]) for row in rows]


def test_every_status_change_is_a_row_by_the_change_timeline(run_dir):
    transitions = [json.loads(line) for line in (run_dir / "transitions.jsonl").read_text().splitlines()]
    logged = [(r["tick"], r["node"], r["to"]) for r in transitions]
    rows = _query(run_dir / "recording.rrd", "tree/status", CHANGE_TIMELINE)
    assert [row[CHANGE_TIMELINE] for row in rows] == list(range(len(transitions)))
    assert _statuses(rows) == logged
    assert [row["cell_time"].total_seconds() for row in rows] == pytest.approx([r["t"] for r in transitions])
    by_tick = _query(run_dir / "recording.rrd", "tree/status", "tick")
    assert len(by_tick) == len({r["tick"] for r in transitions}) < len(transitions)  # one row a tick
    texts = _query(run_dir / "recording.rrd", "tree/transitions", CHANGE_TIMELINE)
    assert [row["/tree/transitions:TextLog:text"][0].split(":")[0] for row in texts] == [r["node"] for r in transitions]


def test_a_recording_built_from_an_old_runs_logs_numbers_its_changes_too(run_dir, tmp_path):
    transitions = [json.loads(line) for line in (run_dir / "transitions.jsonl").read_text().splitlines()]
    built = recording_from_logs(run_dir, tmp_path / "from_logs.rrd")
    rows = _query(built, "tree/status", CHANGE_TIMELINE)
    assert _statuses(rows) == [(r["tick"], r["node"], r["to"]) for r in transitions]
