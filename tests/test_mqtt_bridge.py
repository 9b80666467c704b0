"""The live design bridge over a real MQTT broker (tests/mqtt_broker.py): the plan and the status
changes arrive in order and read as COMPAS data, design updates join the build at the next element
boundary, conflicts and malformed messages are answered and never stop the cell, and a broker
restart mid-run loses nothing. The element builds are scripted (two ticks each) except in the last
test, a whole `fvtree run --bridge` of the flagship assembly on the simulated cell."""

from __future__ import annotations

import importlib.util
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import py_trees
from compas.datastructures import Graph
from compas.geometry import Frame
from mqtt_broker import mqtt_broker_fixture, wait_for  # noqa: F401 - the fixture
from py_trees.common import Access, Status

from assembly.cli import main
from assembly.design.bridge import DesignBridge
from assembly.design.link.compas_data import from_graph, pose_to_frame
from assembly.design.link.mqtt_bridge import MqttLink
from assembly.design.link.transport import LinkTransport
from assembly.design.link.workspace import Workspace
from assembly.design.model import DesignModel
from assembly.nodes.for_each_element import ForEachElement
from behaviours.skill_kit import keys

ROOT = Path(__file__).resolve().parents[1]
DESIGN = ROOT / "trees" / "design" / "two_bays.json"
_spec = importlib.util.spec_from_file_location("design_client", ROOT / "examples" / "design_client.py")
design_client = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(design_client)


class ScriptedBuild(py_trees.behaviour.Behaviour):
    """Builds the element for_each_element publishes in two ticks: `placing`, then `placed` at a
    pose 1 m above its pick pose, carrying 10 N plus its index."""

    def __init__(self):
        super().__init__("build")
        self.bb = self.attach_blackboard_client("build")
        self.bb.register_key(key=keys.ELEMENT, access=Access.READ)
        self.bb.register_key(key=keys.ASBUILT, access=Access.WRITE)

    def initialise(self) -> None:
        self.step = 0

    def update(self) -> Status:
        element = self.bb.get(keys.ELEMENT)
        self.step += 1
        pose = (np.array(element["pick_pose"]) + [0, 0, 1.0, 0, 0, 0]).tolist()
        status = "placing" if self.step == 1 else "placed"
        self.bb.set(keys.ASBUILT, {"element": element["id"], "status": status, "pose": pose,
                                   "load": 10.0 + int(element["id"][1:])}, overwrite=True)
        return Status.RUNNING if status == "placing" else Status.SUCCESS


class ScriptedRun:
    """A design bridge with an MQTT link and a for_each_element over the scripted build."""

    def __init__(self, tmp_path: Path, url: str, cell: str, design: Path = DESIGN):
        self.link = MqttLink(url, cell, workspace=Workspace.of_cell("sim"))
        self.bridge = DesignBridge(DesignModel.load(design), tmp_path / "asbuilt.json", tmp_path / "events.jsonl",
                                   links=[self.link])
        self.node = ForEachElement("elements", ScriptedBuild())
        self.node.setup(design=self.bridge.model, bridge=self.bridge)
        self.bridge.event("start", cell=cell)

    def tick(self, n: int = 1) -> Status:
        for _ in range(n):
            self.node.tick_once()
        return self.node.status

    def until(self, element: str, status: str, limit: int = 50) -> None:
        for _ in range(limit):
            if self.bridge.model.graph.nodes[element].get("status") == status:
                return
            self.tick()
        raise AssertionError(f"{element} never became {status}")

    def finish(self) -> list[str]:
        """Tick to the end; the elements in the order they were placed."""
        for _ in range(100):
            if self.tick() != Status.RUNNING:
                break
        assert self.node.status == Status.SUCCESS, self.node.feedback_message
        self.bridge.event("end", status="SUCCESS")
        events = [json.loads(line) for line in self.bridge.events_path.read_text().splitlines()]
        return [e["element"] for e in events if e["event"] == "placed"]


def client(url: str, cell: str, durable: bool = False):
    """The example client (compas_eve only), connected and subscribed."""
    transport = LinkTransport(url, f"test-client-{cell}") if durable else None
    c = design_client.DesignClient(url, cell, transport)
    wait_for(lambda: c.transport._is_connected, 120, "the client to connect")
    return c


def statuses(c) -> list[tuple[str, str]]:
    seen = [(m["element"], m["status"]) for m in c.statuses]
    return [s for i, s in enumerate(seen) if i == 0 or s != seen[i - 1]]  # QoS 1 may repeat one after a restart


def test_plan_and_status_arrive_in_order_as_compas_data(mqtt_broker, tmp_path):
    c = client(mqtt_broker.url, "order")
    run = ScriptedRun(tmp_path, mqtt_broker.url, "order")
    assert run.finish() == ["E1", "E2"]
    assert run.link.close() == 0
    want = [(e, s) for e in ("E1", "E2") for s in ("picking", "placing", "placed")]
    wait_for(lambda: len(c.statuses) >= len(want) and c.plan and len(c.events) >= 2, 120, "every message")
    assert statuses(c) == want
    placed = [m for m in c.statuses if m["status"] == "placed"]
    for m in placed:
        assert isinstance(m["frame"], Frame) and m["cell"] == "order"
        pose = run.bridge.model.graph.nodes[m["element"]]["asbuilt_pose"]
        assert np.allclose(list(m["frame"].point), pose[:3])
    assert [m["load"] for m in placed] == [11.0, 12.0]
    assert [m["event"] for m in c.events] == ["start", "end"]
    assert isinstance(c.plan, Graph)
    plan = from_graph(c.plan)  # the retained plan is the as-built model
    assert plan.to_data() == run.bridge.model.to_data() or all(plan.is_placed(e) for e in ("E1", "E2"))
    assert [e["status"] for e in c.elements()] == ["placed", "placed"]
    c.close()


def test_a_design_update_joins_the_build_at_the_next_element_boundary(mqtt_broker, tmp_path):
    c = client(mqtt_broker.url, "updates")
    run = ScriptedRun(tmp_path, mqtt_broker.url, "updates")
    run.until("E1", "placing")
    # The link subscribes to updates on connecting, before it sends what it queued: once its status
    # reaches the client, the broker has its subscription (messages before it are not kept).
    wait_for(lambda: ("E1", "placing") in statuses(c), 120, "the cell's link")  # the run never waits for it
    new = {"id": "E3", "plate": "P1", "size": [0.3, 0.04, 0.04], "pick_pose": [0.3, -0.6, 0.02, 0, 0, 0],
           "planned_pose": pose_to_frame([-0.1, 0.3, 0.2, 0, -1.5707963, 0])}  # a COMPAS frame is a pose too
    c.send({"update": "add-E3", "elements": [new], "edges": [{"source": "E3", "target": "E2"}]})
    wait_for(lambda: c.plan is not None, 120, "the plan")
    c.change_planned("E2", pose_to_frame([0.0, 0.62, 0.2, 0, -1.5707963, 0]), "move-E2")  # as Grasshopper does
    wait_for(lambda: run.link.pending() == 2, 120, "the updates to reach the cell")
    assert run.bridge.model.graph.nodes["E1"]["status"] == "placing"  # not applied mid-element
    assert "E3" not in run.bridge.model.graph
    assert run.finish() == ["E1", "E3", "E2"]  # E2 now waits for E3
    model = DesignModel.load(tmp_path / "asbuilt.json")  # the record of truth has it
    assert model.graph.nodes["E3"]["status"] == "placed"
    assert np.allclose(model.graph.nodes["E3"]["planned_pose"], [-0.1, 0.3, 0.2, 0, -1.5707963, 0])
    assert np.allclose(model.graph.nodes["E2"]["planned_pose"], [0.0, 0.62, 0.2, 0, -1.5707963, 0])
    assert model.graph.nodes["E2"]["pick_pose"] == DesignModel.load(DESIGN).graph.nodes["E2"]["pick_pose"]
    events = [json.loads(line) for line in (tmp_path / "events.jsonl").read_text().splitlines()]
    assert {"event": "design_updated", "elements": ["E3", "E2"]}.items() <= next(
        e for e in events if e["event"] == "design_updated").items()
    run.link.close()
    c.close()
    shown = subprocess.run([sys.executable, str(ROOT / "examples" / "design_client.py"), "--broker", mqtt_broker.url,
                            "--cell", "updates", "--watch", "1"], capture_output=True, text=True, timeout=120, check=True)
    for eid in ("E1", "E2", "E3"):  # the example client shows the retained plan: all three placed
        assert re.search(rf"^  {eid} +placed +at \(.*\), 1[123]\.00 N$", shown.stdout, re.MULTILINE), shown.stdout


BAD = {  # update sent -> where the answer goes and what it says
    "change-placed": ({"update": "change-placed", "elements": [{"id": "E1", "plate": "P2", "size": [0.4, 0.04, 0.04],
                                                                "pick_pose": [0.3, -0.45, 0.02, 0, 0, 0]}]},
                      "conflicts", "E1 cannot change: it is placed"),
    "wait-placed": ({"update": "wait-placed", "edges": [{"source": "E2", "target": "E1"}]},
                    "conflicts", "E1 cannot be made to wait for E2: it is placed"),
    "cycle": ({"update": "cycle", "elements": [{"id": i, "plate": "P1", "size": [0.4, 0.04, 0.04],
                                                 "pick_pose": [0, 0, 0, 0, 0, 0]} for i in ("E4", "E8")],
               "edges": [{"source": "E4", "target": "E8"}, {"source": "E8", "target": "E4"}]},
              "errors", "precedence cycle"),
    "typo": ({"update": "typo", "elements": [{"id": "E5", "plate": "P1", "sise": [0.4, 0.04, 0.04],
                                               "pick_pose": [0, 0, 0, 0, 0, 0]}]}, "errors", "unknown field 'sise'"),
    "no-plate": ({"update": "no-plate", "elements": [{"id": "E6", "plate": "P7", "size": [0.4, 0.04, 0.04],
                                                       "pick_pose": [0, 0, 0, 0, 0, 0]}]}, "errors", "'P7'"),
    "status": ({"update": "status", "elements": [{"id": "E2", "status": "placed", "plate": "P2",
                                                   "size": [0.4, 0.04, 0.04], "pick_pose": [0, 0, 0, 0, 0, 0]}]},
               "errors", "recorded by the cell"),
    "class": ({"update": "class", "elements": [{"id": "E7", "plate": "P1", "size": [0.4, 0.04, 0.04],
                                                "pick_pose": {"dtype": "os/system", "data": {}}}]},
              "errors", "compas.geometry/Frame"),
}


def test_conflicts_and_malformed_messages_are_answered_and_the_cell_goes_on(mqtt_broker, tmp_path):
    c = client(mqtt_broker.url, "bad")
    run = ScriptedRun(tmp_path, mqtt_broker.url, "bad")
    run.until("E1", "placed")
    wait_for(lambda: ("E1", "placed") in statuses(c), 120, "the cell's link")  # subscribed: see above
    for update, _, _ in BAD.values():
        c.send(update)
    raw = LinkTransport(mqtt_broker.url, "test-raw")  # what compas_eve would never send
    wait_for(lambda: raw._is_connected, 120, "the raw client")
    for payload in (b"{not json", b"[1, 2]", b"\xff\xfe", json.dumps({"update": 1, "elements": "E1"}).encode(),
                    b'{"update": "deep", "elements": ' + b"[" * 50 + b"]" * 50 + b"}", b"x" * 300_000):
        raw.client.publish("fvtree/bad/updates", payload, qos=1)
    wait_for(lambda: run.link.received >= len(BAD) + 6, 120, "every message to reach the cell")
    assert run.finish() == ["E1", "E2"]  # nothing stopped the cell, nothing changed the design
    assert set(run.bridge.model.elements()) == {"E1", "E2"}
    run.link.close()
    wait_for(lambda: len(c.conflicts) + len(c.errors) >= len(BAD) + 6, 120, "every answer")
    answers = {m["update"]: ("conflicts", m["reason"]) for m in c.conflicts}
    answers.update({m["update"]: ("errors", m["error"]) for m in c.errors if m["update"] is not None})
    for name, (_, topic, words) in BAD.items():
        assert answers[name][0] == topic and words in answers[name][1], (name, answers[name])
    unread = [m["error"] for m in c.errors if m["update"] is None]
    assert len(unread) == 5 and any("not JSON" in e for e in unread) and any("bytes" in e for e in unread)
    assert any("deeper" in e for e in unread) and any("JSON object" in e for e in unread)
    assert answers[1][0] == "errors" and "lists" in answers[1][1]
    raw.close()
    c.close()


def test_a_broker_restart_mid_run_loses_nothing(mqtt_broker, tmp_path):
    c = client(mqtt_broker.url, "restart", durable=True)  # a designer's client that reconnects too ...
    c.transport.client.reconnect_delay_set(0.05, 0.1)  # ... and first: MQTT drops what nobody subscribed to
    run = ScriptedRun(tmp_path, mqtt_broker.url, "restart")
    run.until("E1", "placed")
    wait_for(lambda: ("E1", "placed") in statuses(c), 120, "E1 placed before the outage")
    run.link.transport.client.reconnect_delay_set(3.0, 6.0)  # the cell comes back after the designer's client
    mqtt_broker.stop()
    assert run.finish() == ["E1", "E2"]  # the run goes on while the broker is down
    assert DesignModel.load(tmp_path / "asbuilt.json").is_placed("E2")  # and records every placement
    assert run.link.transport.unacknowledged() > 0  # held for the broker
    mqtt_broker.start()
    want = [(e, s) for e in ("E1", "E2") for s in ("picking", "placing", "placed")]
    wait_for(lambda: statuses(c) == want, 120, f"every status after the restart (got {statuses(c)})")
    assert run.link.close() == 0
    wait_for(lambda: [m["event"] for m in c.events][-1:] == ["end"], 120, "the end event")
    assert all(plan_status == "placed" for plan_status in [e["status"] for e in c.elements()])
    c.close()


def test_fvtree_run_with_a_bridge_mirrors_the_event_log(mqtt_broker, tmp_path):
    c = client(mqtt_broker.url, "flagship")
    code = main(["run", str(ROOT / "trees" / "assembly.yaml"), "--bridge", mqtt_broker.url, "--cell-name", "flagship",
                 "--runs-dir", str(tmp_path), "--no-plots", "--no-record"])
    run_dir = next(tmp_path.iterdir())
    log = [json.loads(line) for line in (run_dir / "events.jsonl").read_text().splitlines()]
    recorded = [(e["element"], e["event"]) for e in log if e["event"] in ("placing", "placed")]
    wait_for(lambda: c.events and c.events[-1]["event"] == "end", 60, "the end of the run")
    assert [(e, s) for e, s in statuses(c) if s != "picking"] == recorded
    assert statuses(c)[0] == ("E1", "picking")
    assert [m["event"] for m in c.events] == [e["event"] for e in log if e["event"] not in ("placing", "placed")]
    assert code == 0 and recorded == [("E1", "placing"), ("E1", "placed"), ("E2", "placing"), ("E2", "placed")]
    c.close()
