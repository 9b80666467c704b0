"""Several cells on one design through the coordinator, over a real broker: two cell processes
build six_bays (six elements, precedence across the cells) and every element is placed exactly
once, in a valid order; a cell that dies loses its claim after the lease and a restarted cell
resumes; a report under a wrong lease and a malformed request are refused.

Leases run on a clock the test moves (`ManualClock`) wherever a test is about their expiry, so a
loaded machine that is slow to restart a cell cannot make a lease run out early; elsewhere they are
far longer than any test."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mqtt_broker import mqtt_broker_fixture, wait_for  # noqa: F401 - the fixture

from assembly.design.link.coordinator import Coordinator
from assembly.design.link.transport import LinkTransport
from assembly.design.model import DesignModel

ROOT = Path(__file__).resolve().parents[1]
DESIGN = ROOT / "trees" / "design" / "six_bays.json"
CELL = Path(__file__).with_name("coordinated_cell.py")


class ManualClock:
    """The coordinator's clock (seconds), moved only by `advance`."""

    def __init__(self):
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += seconds


def cell(url: str, name: str, run_dir: Path, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, str(CELL), url, name, str(run_dir), *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def events(run_dir: Path) -> list[dict]:
    return [json.loads(line) for line in (run_dir / "events.jsonl").read_text().splitlines()]


def placements(coordinator: Coordinator) -> list[tuple[str, str]]:
    return [(e["element"], e["cell"]) for e in coordinator.log if e["what"] == "placed"]


def assert_valid_order(order: list[str], model: DesignModel) -> None:
    for i, eid in enumerate(order):
        for before in model.graph.predecessors(eid):
            assert before in order[:i], f"{eid} placed before {before}, which it stands on"


@pytest.mark.slow
def test_two_cells_place_every_element_exactly_once_in_a_valid_order(mqtt_broker, tmp_path):
    state = tmp_path / "state.json"
    coordinator = subprocess.Popen([sys.executable, "-m", "assembly.cli", "coordinate", str(DESIGN), "--broker",
                                    mqtt_broker.url, "--lease", "600", "--state", str(state), "--until-done",
                                    "--unsigned"],
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    cells = {name: cell(mqtt_broker.url, name, tmp_path / name) for name in ("A", "B")}
    for name, process in cells.items():
        out, _ = process.communicate(timeout=180)
        assert process.returncode == 0, f"cell {name}:\n{out}"
    out, err = coordinator.communicate(timeout=60)
    assert coordinator.returncode == 0, err
    log = [json.loads(line) for line in out.splitlines()]
    placed = [(e["element"], e["cell"]) for e in log if e["what"] == "placed"]
    order = [e for e, _ in placed]
    assert sorted(order) == ["E1", "E2", "E3", "E4", "E5", "E6"]  # each exactly once
    saved = DesignModel.load(state)
    assert_valid_order(order, saved)
    assert {c for _, c in placed} == {"A", "B"}  # both cells built
    granted = [(e["element"], e["cell"]) for e in log if e["what"] == "granted"]
    assert sorted(granted) == sorted(placed)  # no element granted twice
    assert all(saved.graph.nodes[e]["cell"] == c for e, c in placed)
    for name in ("A", "B"):  # each cell built its own and stood the other's in its world
        own = [e["element"] for e in events(tmp_path / name) if e["event"] == "placed"]
        assert own == [e for e, c in placed if c == name]
        assert set(events(tmp_path / name)[-1]["stood"]) >= {e for e, c in placed if c != name} - {order[-1]}
        assert DesignModel.load(tmp_path / name / "asbuilt.json").is_placed(own[-1])


@pytest.mark.slow
def test_a_dead_cell_loses_its_claim_and_a_restarted_cell_resumes(mqtt_broker, tmp_path):
    lease, clock = 8.0, ManualClock()
    coordinator = Coordinator(DesignModel.load(DESIGN), mqtt_broker.url, lease=lease, clock=clock).start()
    dying = cell(mqtt_broker.url, "A", tmp_path / "A", "--die-at", "E2")
    dying.communicate(timeout=120)
    assert dying.returncode == 9
    claim = next(c for c in coordinator.claims.values() if c.cell == "A")
    assert claim.element == "E2"  # held by the dead cell ...
    clock.advance(0.75 * lease)
    restarted = cell(mqtt_broker.url, "A", tmp_path / "A2", "--die-at", "E3")  # ... which comes back in time
    restarted.communicate(timeout=120)
    grants = [(e["element"], e["cell"], e["lease"]) for e in coordinator.log if e["what"] == "granted"]
    assert ("E2", "A") in [(e, c) for e, c, _ in grants] and ("E2", "A") in placements(coordinator)
    assert len([g for g in grants if g[0] == "E2"]) == 1  # the same claim, resumed: not granted again
    assert coordinator.claims["E3"].cell == "A"  # dead again, but its lease has not run out
    clock.advance(lease + 1.0)
    wait_for(lambda: any(e["what"] == "expired" and e["element"] == "E3" for e in coordinator.log), 60,
             "the dead cell's claim to expire")
    other = cell(mqtt_broker.url, "B", tmp_path / "B")
    out, _ = other.communicate(timeout=180)
    assert other.returncode == 0, out
    coordinator.stop()
    order = [e for e, _ in placements(coordinator)]
    assert sorted(order) == ["E1", "E2", "E3", "E4", "E5", "E6"]
    assert_valid_order(order, coordinator.model)
    assert ("E3", "B") in placements(coordinator)


def test_reports_under_a_wrong_lease_and_malformed_requests_are_refused(mqtt_broker, tmp_path):
    coordinator = Coordinator(DesignModel.load(DESIGN), mqtt_broker.url, lease=30.0).start()
    answers: list[dict] = []
    probe = LinkTransport(mqtt_broker.url, "test-probe")
    probe.listen("fvtree/design/six_bays/cells/X", lambda p: answers.append(json.loads(p)))
    probe.listen("fvtree/design/six_bays/errors", lambda p: answers.append(json.loads(p)))
    wait_for(lambda: probe._is_connected, 120, "the probe to connect")
    time.sleep(0.3)
    claims = "fvtree/design/six_bays/claims"
    probe.send(claims, {"op": "claim", "cell": "X", "request": "r1"})
    grant = wait_for(lambda: next((a for a in answers if a.get("request") == "r1"), None), 120, "the grant")
    assert grant["element"] == "E1"
    probe.send(claims, {"op": "claim", "cell": "Y", "request": "r2"})  # E1 is taken: Y gets E2
    wait_for(lambda: any(e["what"] == "granted" and e["cell"] == "Y" for e in coordinator.log), 120, "Y's grant")
    assert coordinator.claims["E2"].cell == "Y"
    probe.send(claims, {"op": "placed", "cell": "X", "request": "r3", "element": "E1", "lease": "forged",
                        "pose": [0, 0, 0, 0, 0, 0]})
    probe.send(claims, {"op": "placed", "cell": "X", "request": "r4", "element": "E2", "lease": grant["lease"],
                        "pose": [0, 0, 0, 0, 0, 0]})
    probe.client.publish(claims, b"{not json", qos=1)
    probe.send(claims, {"op": "steal", "cell": "X"})
    probe.send(claims, {"op": "claim", "cell": "a/b"})
    wait_for(lambda: len(answers) >= 6, 120, "every answer")  # X: grant, 2 refusals; 3 errors
    by_request = {a.get("request"): a for a in answers if a.get("request")}
    assert "not claimed by X under this lease" in by_request["r3"]["refused"]
    assert "E2 is not claimed by X" in by_request["r4"]["refused"]
    errors = list(dict.fromkeys(a["error"] for a in answers if "error" in a))  # QoS 1: at least once
    assert len(errors) == 3 and "not JSON" in errors[0] and "'op' one of" in errors[1] and "'a/b'" in errors[2]
    assert not any(coordinator.model.is_placed(e) for e in ("E1", "E2"))
    probe.close()
    coordinator.stop()


def test_a_placing_element_is_never_handed_out_again(mqtt_broker):
    lease, clock = 0.5, ManualClock()
    coordinator = Coordinator(DesignModel.load(DESIGN), mqtt_broker.url, lease=lease, clock=clock)
    coordinator._handle(json.dumps({"op": "claim", "cell": "X", "request": "1"}).encode())
    lease_id = coordinator.claims["E1"].lease
    coordinator._handle(json.dumps({"op": "placing", "cell": "X", "lease": lease_id, "element": "E1",
                                    "pose": [0, 0, 0, 0, 0, 0]}).encode())
    clock.advance(lease * 2)
    coordinator._expire()
    assert coordinator.claims["E1"].cell == "" and coordinator.log[-1]["what"] == "stuck"
    coordinator._handle(json.dumps({"op": "claim", "cell": "Y", "request": "2"}).encode())
    assert coordinator.claims["E2"].cell == "Y"  # not E1: it may stand, a person checks it
    coordinator.transport.close()
