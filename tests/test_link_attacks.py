"""Each attack of issue 28 replayed against a real mosquitto, as a hostile client on the same
broker would make it: refused, nothing moves, no as-built model changes.

The secured broker (`secure_broker`: passwords, the ACL file of examples/secure_broker, TLS) shows
the broker's own defences; the open one (`mqtt_broker`: anonymous, no ACLs) shows that what must
be trusted end to end (grants, placed reports, the coordinator's plan) is refused when forged even
where the broker lets anything through, because it is signed with a per-cell secret."""

from __future__ import annotations

import importlib.util
import json
import logging
import os
import secrets
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from compas.datastructures import Graph
from compas_eve import Subscriber, Topic
from mqtt_broker import Broker, free_port, mosquitto, mqtt_broker_fixture, secure_broker_fixture, wait_for  # noqa: F401
from test_coordinator import ManualClock

from assembly.cli import main
from assembly.design.link import signing
from assembly.design.link.coordinator import Coordinator
from assembly.design.link.mqtt_bridge import MqttLink
from assembly.design.link.security import LinkError, LinkSecurity
from assembly.design.link.transport import LinkTransport
from assembly.design.model import DesignModel

ROOT = Path(__file__).resolve().parents[1]
SIX_BAYS = ROOT / "trees" / "design" / "six_bays.json"
CELL = Path(__file__).with_name("coordinated_cell.py")
TOPICS = "fvtree/design/six_bays"


def recorder(url: str, name: str, security: LinkSecurity | None = None, *topics: str) -> tuple[LinkTransport, dict]:
    """A client that keeps every raw message on `topics`, by topic."""
    seen: dict[str, list[bytes]] = {t: [] for t in topics}
    transport = LinkTransport(url, name, security)
    for topic in topics:
        transport.listen(topic, seen[topic].append)
    return transport, seen


def cell_credentials(directory: Path, name: str, secret: bytes) -> Path:
    path = directory / f"{name}.json"
    path.write_text(json.dumps({"secret": secret.hex()}))
    path.chmod(0o600)
    return path


def cell(url: str, name: str, run_dir: Path, credentials: Path, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, str(CELL), url, name, str(run_dir), "--credentials", str(credentials),
                             *extra], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def events(run_dir: Path) -> list[dict]:
    return [json.loads(line) for line in (run_dir / "events.jsonl").read_text().splitlines()]


# ---- 1. no authentication, no TLS ---------------------------------------------------------------
def test_the_secured_broker_refuses_anonymous_and_wrong_logins_at_once(secure_broker):
    for security in (None, LinkSecurity(username="A", password="wrong")):
        with pytest.raises(LinkError, match="refused the connection: Connection Refused: not authorised"):
            LinkTransport(secure_broker.url, "t-refused", security)
    with pytest.raises(LinkError, match="certificate verify failed"):  # TLS without the lab's CA
        LinkTransport(secure_broker.tls_url, "t-no-ca", LinkSecurity.load(secure_broker.credentials("A")))
    for creds in (secure_broker.credentials("A", tls=True), secure_broker.credentials("A", tls=True, client_cert=True)):
        transport = LinkTransport(secure_broker.tls_url, "t-tls", LinkSecurity.load(creds))
        assert transport._is_connected
        transport.close()


def test_a_password_in_the_url_is_refused_and_never_printed(secure_broker, tmp_path, capsys, caplog):
    password = secure_broker.users["A"]["password"]
    url = f"mqtt://A:{password}@127.0.0.1:{secure_broker.port}"
    code = main(["run", str(ROOT / "trees" / "assembly.yaml"), "--bridge", url, "--runs-dir", str(tmp_path),
                 "--no-plots", "--no-record"])
    out, err = capsys.readouterr()
    assert code == 2 and "must not hold a user name or password" in err
    assert password not in out + err + caplog.text


def test_a_run_on_a_refusing_broker_exits_2_at_once_without_the_password(secure_broker, tmp_path, capsys, caplog):
    wrong = tmp_path / "wrong.json"
    wrong.write_text(json.dumps({"username": "A", "password": "not-the-password-123"}))
    wrong.chmod(0o600)
    started = time.monotonic()
    code = main(["run", str(ROOT / "trees" / "assembly.yaml"), "--bridge", secure_broker.url, "--cell-name", "A",
                 "--credentials", str(wrong), "--runs-dir", str(tmp_path / "runs"), "--no-plots", "--no-record"])
    out, err = capsys.readouterr()
    assert code == 2 and "refused the connection" in err and "not authorised" in err
    assert time.monotonic() - started < 60  # at once: not after the run
    assert "not-the-password-123" not in out + err + caplog.text
    assert not any((tmp_path / "runs").glob("*/events.jsonl")) or not any(
        e["event"] == "placed" for f in (tmp_path / "runs").glob("*/events.jsonl")
        for e in map(json.loads, f.read_text().splitlines()))  # nothing was built


def test_a_readable_credentials_file_is_refused(tmp_path):
    creds = tmp_path / "c.json"
    creds.write_text(json.dumps({"username": "A", "password": "p"}))
    creds.chmod(0o644)
    with pytest.raises(LinkError, match="readable by others"):
        LinkSecurity.load(creds)


def test_fvtree_coordinate_on_a_refusing_broker_fails_clearly(secure_broker, tmp_path):
    wrong = tmp_path / "coordinator.json"
    wrong.write_text(json.dumps({"username": "coordinator", "password": "wrong-password-456",
                                 "cells": {"A": secrets.token_hex(32)}}))
    wrong.chmod(0o600)
    done = subprocess.run([sys.executable, "-m", "assembly.cli", "coordinate", str(SIX_BAYS), "--broker",
                           secure_broker.url, "--credentials", str(wrong), "--state", str(tmp_path / "state.json"),
                           "--until-done"], capture_output=True, text=True, timeout=120, cwd=ROOT, check=False)
    assert done.returncode == 2, done.stderr
    assert "refused the connection" in done.stderr and "coordinating" not in done.stderr and not done.stdout
    assert "wrong-password-456" not in done.stderr


def test_a_coordinated_build_without_signing_secrets_is_refused_unless_asked_for(mqtt_broker, tmp_path, capsys):
    done = subprocess.run([sys.executable, "-m", "assembly.cli", "coordinate", str(SIX_BAYS), "--broker",
                           mqtt_broker.url, "--state", str(tmp_path / "state.json"), "--until-done"],
                          capture_output=True, text=True, timeout=120, cwd=ROOT, check=False)
    assert done.returncode == 2 and "no signing secrets of the cells" in done.stderr and "--unsigned" in done.stderr
    code = main(["run", str(ROOT / "trees" / "assembly.yaml"), "--bridge", mqtt_broker.url, "--coordinated",
                 "--runs-dir", str(tmp_path / "runs"), "--no-plots", "--no-record"])
    assert code == 2 and "no signing secret" in capsys.readouterr().err


# ---- ACLs: a cell publishes only on its own topics, only the coordinator on its own -------------
def test_the_acl_drops_what_a_user_may_not_publish(secure_broker):
    watched = ["fvtree/A/plan", "fvtree/A/status", "fvtree/B/status", f"{TOPICS}/cells/A", f"{TOPICS}/plan",
               "fvtree/A/updates"]
    watcher, seen = recorder(secure_broker.url, "t-watch", LinkSecurity.load(secure_broker.credentials("designer")),
                             *watched)
    time.sleep(0.5)
    intruder = LinkTransport(secure_broker.url, "t-intruder", LinkSecurity.load(secure_broker.credentials("intruder")))
    a = LinkTransport(secure_broker.url, "t-a", LinkSecurity.load(secure_broker.credentials("A")))
    designer = LinkTransport(secure_broker.url, "t-designer", LinkSecurity.load(secure_broker.credentials("designer")))
    for topic in watched:
        intruder.send(topic, {"forged": topic}, retain=True)
    a.send("fvtree/B/status", {"forged": "B's status by A"})
    a.send(f"{TOPICS}/cells/A", {"forged": "a grant by A"})
    a.send("fvtree/A/updates", {"forged": "an update by A"})
    a.send("fvtree/A/status", {"element": "E1", "status": "picking"})  # its own topic: allowed
    designer.send("fvtree/A/updates", {"update": "u1", "elements": []})  # a designer's: allowed
    wait_for(lambda: seen["fvtree/A/status"] and seen["fvtree/A/updates"], 60, "the allowed messages")
    for transport in (intruder, a, designer):
        assert transport.close() == 0  # the broker acknowledged (and dropped) every one
    time.sleep(0.5)
    forged = [m for messages in seen.values() for m in messages if b"forged" in m]
    assert forged == []
    watcher.close()


# ---- 2. anyone can move the arm -------------------------------------------------------------------
def test_an_update_outside_the_workspace_is_refused_and_nothing_moves(secure_broker, tmp_path, caplog):
    """A whole `fvtree run` of the flagship over TLS as cell A; a designer (allowed to send updates)
    moves E2's pick pose to the workspace corner [3, -3, 0.02] as E1 is picked."""
    designer = LinkTransport(secure_broker.tls_url, "t-designer-arm",
                             LinkSecurity.load(secure_broker.credentials("designer", tls=True)))
    answers: list[dict] = []
    designer.listen("fvtree/A/errors", lambda p: answers.append(json.loads(p)))
    attack = {"update": "corner", "elements": [{"id": "E2", "plate": "P2", "size": [0.435, 0.04, 0.04], "mass": 0.4,
                                                "pick_pose": [3.0, -3.0, 0.02, 0, 0, 0]}]}

    def on_status(payload: bytes) -> None:
        if json.loads(payload).get("status") == "picking":
            designer.send("fvtree/A/updates", attack)
    designer.listen("fvtree/A/status", on_status)
    caplog.set_level(logging.WARNING)
    code = main(["run", str(ROOT / "trees" / "assembly.yaml"), "--bridge", secure_broker.tls_url, "--cell-name", "A",
                 "--credentials", str(secure_broker.credentials("A", tls=True)), "--runs-dir", str(tmp_path),
                 "--no-plots", "--no-record"])
    assert code == 0
    wait_for(lambda: any(a["update"] == "corner" for a in answers), 60, "the refusal")
    refusal = next(a for a in answers if a["update"] == "corner")["error"]
    assert "refused: E2: pick_pose [3.0, -3.0, 0.02] is outside the cell's workspace" in refusal
    assert "x 3 not in [-0.9, 0.9]" in refusal and "y -3 not in [-0.9, 0.9]" in refusal
    run_dir = next(tmp_path.iterdir())
    model = DesignModel.load(run_dir / "asbuilt.json")
    assert model.graph.nodes["E2"]["pick_pose"] == DesignModel.load(ROOT / "trees/design/two_bays.json").graph.nodes[
        "E2"]["pick_pose"]
    assert not [r for r in caplog.records if "clamped" in r.getMessage()]  # the arm was never sent out of the box
    assert json.loads((run_dir / "summary.json").read_text())["safety_clamps"] == 0
    assert not any(e["event"] == "design_updated" for e in events(run_dir))
    designer.close()


# ---- 3, 4. impersonation, forged placed reports, grants and plans (no ACLs: the open broker) ----
@pytest.mark.slow  # two cell processes / a cell process and a broker killed
def test_forged_claims_grants_reports_and_plans_are_refused_without_acls(mqtt_broker, tmp_path):
    keys = {c: secrets.token_bytes(32) for c in ("A", "B")}
    coordinator = Coordinator(DesignModel.load(SIX_BAYS), mqtt_broker.url, lease=600.0,
                              security=LinkSecurity(cells=keys)).start()
    attacker, seen = recorder(mqtt_broker.url, "t-attacker", None, f"{TOPICS}/claims", f"{TOPICS}/cells/A",
                              f"{TOPICS}/cells/B", f"{TOPICS}/plan")
    time.sleep(0.3)
    claims = f"{TOPICS}/claims"
    attacker.send(claims, {"op": "claim", "cell": "A", "request": "x1"})  # unsigned, in A's name
    attacker.send(claims, signing.sign(secrets.token_bytes(32), {"op": "claim", "cell": "A", "request": "x2"}))
    wait_for(lambda: len([e for e in coordinator.log if e["what"] == "refused"]) >= 2, 60, "the refusals")
    assert not any(e["what"] == "granted" for e in coordinator.log)
    creds = {c: cell_credentials(tmp_path, c, keys[c]) for c in keys}
    a = cell(mqtt_broker.url, "A", tmp_path / "A", creds["A"], "--build-ticks", "150")
    grant = wait_for(lambda: next((json.loads(m) for m in seen[f"{TOPICS}/cells/A"]
                                   if json.loads(m).get("element") == "E1"), None), 120, "A's grant")

    def grant_b_what_a_holds(payload: bytes) -> None:  # answer each of B's claims first, with A's element
        request = json.loads(payload)
        if request.get("cell") == "B" and request.get("op") == "claim":
            attacker.send(f"{TOPICS}/cells/B", {"request": request["request"], "op": "claim", "cell": "B",
                                                "element": "E1", "lease": grant["lease"], "lease_s": 600.0})
    attacker.listen(f"{TOPICS}/claims", grant_b_what_a_holds)
    b = cell(mqtt_broker.url, "B", tmp_path / "B", creds["B"], "--build-ticks", "150")
    wait_for(lambda: seen[f"{TOPICS}/cells/B"], 120, "B asking")
    forged_placed = {"op": "placed", "cell": "A", "request": "x3", "element": "E1", "lease": grant["lease"],
                     "pose": [5.0, 5.0, 5.0, 0, 0, 0], "load": 1e6}
    attacker.send(claims, forged_placed)
    attacker.send(claims, {**forged_placed, "sig": grant["sig"]})  # a signature lifted from another message
    replayed = next(m for m in seen[claims] if json.loads(m).get("cell") == "A" and json.loads(m)["request"][0] != "x")
    attacker.send_raw(claims, replayed)  # A's own signed claim, sent again
    plan = json.loads(seen[f"{TOPICS}/plan"][-1])
    node = plan["data"]["node"]["'E1'"]  # COMPAS keys a Graph's nodes by their repr
    node.update(status="placed", cell="A", measured_load=1e6,
                asbuilt_frame={"dtype": "compas.geometry/Frame", "data": {"point": [5, 5, 5], "xaxis": [1, 0, 0],
                                                                          "yaxis": [0, 1, 0]}})
    plan.pop("signatures", None)
    attacker.send_raw(f"{TOPICS}/plan", json.dumps(plan).encode(), retain=True)  # a forged plan
    for name, process in (("A", a), ("B", b)):
        out, _ = process.communicate(timeout=300)
        assert process.returncode == 0, f"cell {name}:\n{out}"
    coordinator.stop()
    refusals = [e.get("error", "") for e in coordinator.log if e["what"] == "refused"]
    assert sum("not signed" in r for r in refusals) >= 2 and any("bad signature" in r for r in refusals)
    assert any("used before (a replay)" in r for r in refusals), refusals
    placed = [(e["element"], e["cell"]) for e in coordinator.log if e["what"] == "placed"]
    assert sorted(e for e, _ in placed) == ["E1", "E2", "E3", "E4", "E5", "E6"]  # each once, E1 by A
    assert ("E1", "A") in placed
    e1 = coordinator.model.graph.nodes["E1"]
    assert e1["asbuilt_pose"][:3] == [0.3, -0.45, 1.02] and e1["measured_load"] == 20.0  # A's real report
    for name in ("A", "B"):
        own = [e["element"] for e in events(tmp_path / name) if e["event"] == "placed"]
        assert (name == "A") == ("E1" in own)  # B never built E1 on the forged grants ...
        assert name == "A" or events(tmp_path / name)[-1]["forged"] >= 1  # ... which reached it, and were dropped
        as_built = DesignModel.load(tmp_path / name / "asbuilt.json").graph.nodes["E1"]
        assert as_built.get("measured_load") in (None, 20.0) and as_built.get("asbuilt_pose", [0])[:3] != [5, 5, 5]
    attacker.close()


# ---- 4. a cell that is refused stops ---------------------------------------------------------------
def test_a_cell_whose_claim_is_revoked_stops_at_once(mqtt_broker, tmp_path):
    keys = {"A": secrets.token_bytes(32)}
    clock = ManualClock()
    coordinator = Coordinator(DesignModel.load(SIX_BAYS), mqtt_broker.url, lease=8.0, clock=clock,
                              security=LinkSecurity(cells=keys)).start()
    a = cell(mqtt_broker.url, "A", tmp_path / "A", cell_credentials(tmp_path, "A", keys["A"]),
             "--build-ticks", "100000")  # a build that would go on for half an hour
    wait_for(lambda: any(e["what"] == "granted" for e in coordinator.log), 120, "A's grant")
    clock.advance(20.0)  # the coordinator takes the claim back (as when A's renewals stopped reaching it)
    out, _ = a.communicate(timeout=120)
    assert a.returncode == 3, out
    fault = next(e for e in events(tmp_path / "A") if e["event"] == "fault")
    assert fault["element"] == "E1" and "the coordinator refused renew: no live claim" in fault["message"]
    assert not any(e["event"] in ("placing", "placed") for e in events(tmp_path / "A"))  # it built no further
    assert not DesignModel.load(tmp_path / "A" / "asbuilt.json").is_placed("E1")
    assert not coordinator.model.is_placed("E1") and "E1" not in coordinator.claims  # free for another cell
    coordinator.stop()


# ---- 5. one retained message kills designers' clients ---------------------------------------------
def test_a_bad_retained_plan_stops_no_client(mqtt_broker, secure_broker):
    """On the secured broker the ACL keeps the bad plan out: a plain compas_eve client (no
    protection of its own) goes on hearing the cell. On an open broker the example client and
    fvtree's own subscribers read it, drop it and go on."""
    bad = json.dumps({"dtype": "compas.datastructures/Graph", "data": {"not": "a graph"}}).encode()  # its decode
    # raises in paho's network thread: a compas_eve client without a guard goes deaf (checked on main's example)
    intruder = LinkTransport(secure_broker.url, "t-bad-plan", LinkSecurity.load(secure_broker.credentials("intruder")))
    intruder.send_raw("fvtree/A/plan", bad, retain=True)
    assert intruder.close() == 0
    spec = importlib.util.spec_from_file_location("design_client", ROOT / "examples" / "design_client.py")
    design_client = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(design_client)
    designer = LinkSecurity.load(secure_broker.credentials("designer"))
    plain = design_client.LoginTransport(secure_broker.url, designer.username, designer.password)  # compas_eve's ...
    plain.client.suppress_exceptions = False  # ... with a login, and as unprotected as compas_eve's own
    heard: dict[str, list] = {"plan": [], "status": []}
    for leaf, messages in heard.items():
        Subscriber(Topic(f"fvtree/A/{leaf}"), callback=messages.append, transport=plain).subscribe()
    wait_for(lambda: plain._is_connected, 60, "the plain client")
    time.sleep(0.5)
    a = LinkTransport(secure_broker.url, "t-a-status", LinkSecurity.load(secure_broker.credentials("A")))
    a.send("fvtree/A/status", {"element": "E1", "status": "picking-after-bad-plan"})
    wait_for(lambda: any(m["status"] == "picking-after-bad-plan" for m in heard["status"]), 60,
             "the cell's status on a plain compas_eve client")
    assert all(isinstance(p, Graph) for p in heard["plan"])  # a run's real plan, if any: never the bad one
    a.close()
    plain.close()

    raw = LinkTransport(mqtt_broker.url, "t-bad-open")
    raw.send_raw("fvtree/deaf/plan", bad, retain=True)
    assert raw.close() == 0
    client = design_client.DesignClient(mqtt_broker.url, "deaf")
    wait_for(lambda: client.transport._is_connected, 60, "the example client")
    time.sleep(0.5)  # the bad plan arrives and is dropped
    cell_side = LinkTransport(mqtt_broker.url, "t-deaf-cell")
    cell_side.send("fvtree/deaf/status", {"element": "E1", "status": "placed"})
    wait_for(lambda: client.statuses, 60, "a status after the bad plan")
    assert client.plan is None and client.dropped and "not a COMPAS Graph" in client.dropped[0]
    cell_side.close()
    client.close()


# ---- the README's lab setup, from scratch ----------------------------------------------------------
def test_the_lab_setup_script_makes_a_working_secured_broker(tmp_path):
    """examples/secure_broker/make_lab.sh as the README runs it: mosquitto starts on its files, every
    user logs in over TLS with its credentials file, and the ACL holds."""
    if mosquitto() is None:
        pytest.skip("needs mosquitto (apt-get install mosquitto; .ci/run does)")
    port = free_port()
    lab = tmp_path / "lab"
    subprocess.run([str(ROOT / "examples" / "secure_broker" / "make_lab.sh"), str(lab), "127.0.0.1", "A", "B"],
                   check=True, capture_output=True, timeout=300, env={**os.environ, "PORT": str(port),
                                                                       "BIND": "127.0.0.1"})
    config = lab / "mosquitto.conf"
    if os.getuid() == 0:  # the test's folders are private to root: do not drop to the mosquitto user
        config.write_text(config.read_text() + "user root\n")
    broker = subprocess.Popen([str(mosquitto()), "-c", str(config)], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: socket_open(port), 60, "the lab broker")
        url = f"mqtts://127.0.0.1:{port}"
        users = {u: LinkSecurity.load(lab / "credentials" / f"{u}.json") for u in ("coordinator", "designer", "A", "B")}
        assert set(users["coordinator"].cells) == {"A", "B"} and users["A"].secret == users["coordinator"].cells["A"]
        designer, seen = recorder(url, "lab-designer", users["designer"], "fvtree/A/status", "fvtree/B/status")
        time.sleep(0.5)
        a = LinkTransport(url, "lab-a", users["A"])
        a.send("fvtree/A/status", {"status": "mine"})
        a.send("fvtree/B/status", {"status": "forged"})
        wait_for(lambda: seen["fvtree/A/status"], 60, "A's status")
        assert a.close() == 0
        time.sleep(0.5)
        assert seen["fvtree/B/status"] == []
        with pytest.raises(LinkError, match="not authorised"):
            LinkTransport(url, "lab-nobody", LinkSecurity(username="A", password="guess", ca=lab / "ca.crt"))
        designer.close()
    finally:
        broker.kill()
        broker.wait(timeout=30)


def socket_open(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.5):
            return True
    except OSError:
        return False


def test_a_coordinated_fvtree_run_whose_claim_is_taken_back_ends_fault_at_once(mqtt_broker, tmp_path):
    """A whole `fvtree run --coordinated` (paced to the wall clock, so E1 takes minutes): the
    coordinator takes A's claim back as soon as it is granted; the run stops FAULT with the reason
    within a few seconds, with E1 neither placing nor placed."""
    keys = {"A": secrets.token_bytes(32)}
    clock = ManualClock()
    coordinator = Coordinator(DesignModel.load(ROOT / "trees" / "design" / "two_bays.json"), mqtt_broker.url,
                              lease=10.0, clock=clock, security=LinkSecurity(cells=keys)).start()

    def take_back() -> None:
        wait_for(lambda: any(e["what"] == "granted" for e in coordinator.log), 120, "A's grant")
        clock.advance(60.0)
    threading.Thread(target=take_back, daemon=True).start()
    started = time.monotonic()
    code = main(["run", str(ROOT / "trees" / "assembly.yaml"), "--bridge", mqtt_broker.url, "--cell-name", "A",
                 "--coordinated", "--credentials", str(cell_credentials(tmp_path, "A", keys["A"])), "--speed",
                 "realtime", "--runs-dir", str(tmp_path / "runs"), "--no-plots", "--no-record"])
    assert code == 3  # FAULT
    assert time.monotonic() - started < 60  # the element would take minutes: stopped at once
    run_dir = next((tmp_path / "runs").iterdir())
    log = events(run_dir)
    halted = next(e for e in log if e["event"] == "halted")  # the stop policy's halt: tree, arm, gripper
    assert halted["status"] == "FAULT" and "design link: the coordinator refused renew: no live claim" in halted[
        "message"]
    assert not any(e["event"] in ("placing", "placed") for e in log)
    assert not DesignModel.load(run_dir / "asbuilt.json").is_placed("E1")
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["status"] == "FAULT" and "refused renew" in summary["message"]
    coordinator.stop()


@pytest.mark.slow  # two cell processes / a cell process and a broker killed
def test_a_coordinated_cell_that_loses_the_broker_for_longer_than_the_limit_stops(tmp_path):
    (tmp_path / "broker").mkdir()
    broker = Broker(tmp_path / "broker").start()  # its own: this test kills it
    try:
        keys = {"A": secrets.token_bytes(32)}
        coordinator = Coordinator(DesignModel.load(SIX_BAYS), broker.url, lease=600.0,
                                  security=LinkSecurity(cells=keys)).start()
        a = cell(broker.url, "A", tmp_path / "A", cell_credentials(tmp_path, "A", keys["A"]), "--build-ticks",
                 "100000", "--lost-after", "2")
        wait_for(lambda: any(e["what"] == "granted" for e in coordinator.log), 120, "A's grant")
        broker.stop()
        out, _ = a.communicate(timeout=120)
        assert a.returncode == 3, out
        fault = next(e for e in events(tmp_path / "A") if e["event"] == "fault")
        assert "link to the broker" in fault["message"] and "(limit 2 s)" in fault["message"]
        assert not any(e["event"] in ("placing", "placed") for e in events(tmp_path / "A"))
        coordinator.transport.client.loop_stop()
    finally:
        broker.stop()


def test_a_login_revoked_mid_run_is_the_links_fault(tmp_path):
    """The broker restarts with A's password changed (an account revoked): A's reconnect is refused
    and its link names the fault, which the run's stop policy turns into FAULT."""
    (tmp_path / "broker").mkdir()
    broker = Broker(tmp_path / "broker", secure=True).start()
    try:
        link = MqttLink(broker.url, "A", security=LinkSecurity.load(broker.credentials("A")))
        assert link.fault() is None
        link.transport.client.reconnect_delay_set(0.05, 0.2)
        broker.stop()
        subprocess.run(["mosquitto_passwd", "-b", str(broker.directory / "passwd"), "A", "revoked-" + secrets.token_hex(8)],
                       check=True, capture_output=True, timeout=60)
        broker.start()
        reason = wait_for(link.fault, 60, "the refused reconnect")
        assert "refused the connection: Connection Refused: not authorised" in reason
        assert broker.users["A"]["password"] not in reason
        link.transport.client.loop_stop()
    finally:
        broker.stop()
