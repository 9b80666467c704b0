"""The design link bounded and robust, on a real broker: updates waiting for the next element
boundary are capped (oldest dropped and reported), repeats dropped, junk refused on arrival without
being kept, refusals answered at a bounded rate; and a plain compas_eve client (no protection of
its own: an exception in its decode stops paho's network thread) reads every message fvtree
publishes, a cell's and a signing coordinator's, and is still listening at the end."""

from __future__ import annotations

import json
import secrets
import time
from pathlib import Path

from compas.datastructures import Graph
from compas_eve import Subscriber, Topic
from compas_eve.mqtt import MqttTransport
from mqtt_broker import mqtt_broker_fixture, wait_for  # noqa: F401 - the fixture
from test_mqtt_bridge import BAD, ScriptedRun

from assembly.design.link import mqtt_bridge, signing
from assembly.design.link.cell_claims import ClaimClient
from assembly.design.link.compas_data import to_graph
from assembly.design.link.coordinator import Coordinator
from assembly.design.link.security import LinkSecurity
from assembly.design.link.transport import LinkTransport
from assembly.design.model import DesignModel

ROOT = Path(__file__).resolve().parents[1]


def new_element(i: int) -> dict:
    return {"id": f"N{i}", "plate": "P1", "size": [0.3, 0.04, 0.04], "pick_pose": [0.3, -0.6, 0.02, 0, 0, 0]}


def test_waiting_updates_are_capped_repeats_dropped_and_junk_not_kept(mqtt_broker, tmp_path):
    run = ScriptedRun(tmp_path, mqtt_broker.url, "bounded")
    errors: list[dict] = []
    sender = LinkTransport(mqtt_broker.url, "t-flood")
    sender.listen("fvtree/bounded/errors", lambda p: errors.append(json.loads(p)))
    time.sleep(0.3)
    count = 3 * mqtt_bridge.MAX_QUEUED
    for i in range(count):  # distinct valid updates, all before the first element boundary
        sender.send("fvtree/bounded/updates", {"update": f"u{i}", "elements": [new_element(i)]})
    repeat = json.dumps({"update": "again", "elements": [new_element(999)]}).encode()
    for _ in range(10):
        sender.send_raw("fvtree/bounded/updates", repeat)
    for i in range(300):  # junk, each distinct
        sender.send_raw("fvtree/bounded/updates", f"junk {i} {secrets.token_hex(64)}".encode())
    wait_for(lambda: run.link.received == count + 10 + 300, 120, "every message to reach the cell")
    link = run.link
    assert link.pending() == mqtt_bridge.MAX_QUEUED and link.repeats == 9 and link.refused == 300
    assert link.dropped == count + 1 - mqtt_bridge.MAX_QUEUED
    assert link._queued_bytes < mqtt_bridge.MAX_QUEUED_BYTES
    run.tick()  # the first boundary: the newest updates join the design, the oldest were dropped
    added = [e for e in run.bridge.model.elements() if e.startswith("N")]
    assert len(added) == mqtt_bridge.MAX_QUEUED and "N999" in added and "N0" not in added
    sender.close(timeout=30)
    wait_for(lambda: errors, 60, "the reports")
    time.sleep(1.0)
    dropped = [e for e in errors if "dropped unapplied" in e["error"]]
    assert dropped and dropped[0]["update"] == "u0"
    answered = len(errors) + sum(e.get("unreported", 0) for e in errors)
    assert len(errors) < count + 300  # rate-limited (REPORTS_PER_S) ...
    assert answered <= link.dropped + link.refused  # ... and the rest counted in later reports
    run.link.close()


def plain_client(url: str, topics: list[str]) -> tuple[MqttTransport, dict[str, list]]:
    """compas_eve's own client with a Subscriber per topic, as a designer's script would have."""
    transport = MqttTransport("127.0.0.1", int(url.rsplit(":", 1)[1]))
    heard: dict[str, list] = {t: [] for t in topics}
    for topic in topics:
        Subscriber(Topic(topic), callback=heard[topic].append, transport=transport).subscribe()
    wait_for(lambda: transport._is_connected, 60, "the plain client")
    return transport, heard


def test_a_plain_compas_eve_client_reads_everything_fvtree_publishes(mqtt_broker, tmp_path):
    cell_topics = [f"fvtree/plain/{leaf}" for leaf in ("plan", "status", "events", "conflicts", "errors")]
    design = "fvtree/design/six_bays"
    coordinator_topics = [f"{design}/{leaf}" for leaf in ("plan", "log", "errors", "cells/X")]
    transport, heard = plain_client(mqtt_broker.url, cell_topics + coordinator_topics)
    time.sleep(0.5)
    run = ScriptedRun(tmp_path, mqtt_broker.url, "plain")
    run.until("E1", "placed")
    wait_for(lambda: heard["fvtree/plain/status"], 60, "the cell's status")
    raw = LinkTransport(mqtt_broker.url, "t-plain-raw")
    for update, _, _ in BAD.values():  # every kind of refusal the cell answers
        raw.send("fvtree/plain/updates", update)
    for payload in (b"{not json", b'{"update": {"dtype": "os/system", "data": {}}}', b"\xff", b"x" * 300_000):
        raw.send_raw("fvtree/plain/updates", payload)
    wait_for(lambda: run.link.received >= len(BAD) + 4, 120, "the updates")
    assert run.finish() == ["E1", "E2"]
    run.link.close()
    keys = {"X": secrets.token_bytes(32)}
    coordinator = Coordinator(DesignModel.load(ROOT / "trees" / "design" / "six_bays.json"), mqtt_broker.url,
                              lease=30.0, security=LinkSecurity(cells=keys)).start()
    raw.send(f"{design}/claims", {"op": "claim", "cell": "X", "request": "unsigned"})  # refused: errors topic
    raw.send_raw(f"{design}/claims", b"{not json")
    raw.send(f"{design}/claims", signing.sign(keys["X"], {"op": "claim", "cell": "X", "request": "r1"}))
    wait_for(lambda: heard[f"{design}/cells/X"] and len(heard[f"{design}/errors"]) >= 2, 120, "the coordinator")
    coordinator.stop()
    raw.send("fvtree/plain/status", {"element": "E9", "status": "last"})  # still listening?
    wait_for(lambda: heard["fvtree/plain/status"][-1:] and heard["fvtree/plain/status"][-1]["status"] == "last",
             60, "the last message: the plain client is still listening")
    assert isinstance(heard["fvtree/plain/plan"][-1], Graph) and isinstance(heard[f"{design}/plan"][-1], Graph)
    assert len(heard["fvtree/plain/errors"]) >= 9 and heard["fvtree/plain/conflicts"]
    assert heard[f"{design}/cells/X"][0]["element"] == "E1" and heard[f"{design}/log"]
    raw.close()
    transport.close()


def test_a_cells_claim_client_drops_a_bad_plan_and_reads_the_next(mqtt_broker):
    """fvtree's own subscriber of the coordinator's plan checks it before decoding: the retained
    plan that stops an unguarded compas_eve client, and other junk, are dropped; a good plan reads."""
    transport = LinkTransport(mqtt_broker.url, "t-claims-plan")
    claims = ClaimClient(transport, "X", "six_bays")
    for bad in (json.dumps({"dtype": "compas.datastructures/Graph", "data": {"not": "a graph"}}).encode(),
                b'{"data": {"node": {"x": 1}, "edge": []}}', b"[]", b"\xff", b"{" * 100_000):
        assert claims._read_plan(bad) is None
    good = transport.codec.encode(to_graph(DesignModel.load(ROOT / "trees" / "design" / "six_bays.json")))
    assert isinstance(claims._read_plan(good.encode() if isinstance(good, str) else good), Graph)
    claims.close()
    transport.close()
