"""`fvtree run --groot2`: the run served over BehaviorTree.CPP's Groot2 protocol, watched by a client
written from the protocol (tests/groot2_client.py) and by btview, a third-party Groot2 monitor."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import msgpack
import pytest
from groot2_client import Client, ServerError
from py_trees.blackboard import Blackboard
from py_trees.common import Status

from assembly.cli import main, parser
from assembly.cli.run import run_options
from assembly.interop.groot2 import free_port_pair
from assembly.language.build import build
from assembly.language.reader import load_tree
from assembly.run.options import RunOptions
from assembly.run.session import Run

ROOT = Path(__file__).resolve().parent.parent
ASSEMBLY = ROOT / "trees" / "assembly.yaml"
HOLD = ROOT / "trees" / "hold.yaml"
CODES = {Status.INVALID: 0, Status.RUNNING: 1, Status.SUCCESS: 2, Status.FAILURE: 3}


def monitored(tree: Path, tmp_path: Path, **options) -> tuple[Run, Client]:
    port = free_port_pair()
    run = Run(tree, RunOptions(runs_dir=tmp_path, quiet=True, plots=False, record=False,
                               groot2=("127.0.0.1", port), **options))
    run.open()
    return run, Client(port)


@pytest.fixture
def assembly(tmp_path):
    run, client = monitored(ASSEMBLY, tmp_path)
    yield run, client
    client.close()
    run.close()


def node_elements(xml: str) -> list[ET.Element]:
    """Every node element of a FULLTREE reply (what is inside the <BehaviorTree> blocks)."""
    root = ET.fromstring(xml)
    return [e for block in root.findall("BehaviorTree") for e in block.iter() if e is not block]


def fvtree_uids(xml: str) -> dict[str, int]:
    """Each node's uid by its fvtree path (its `name` and those of the nodes above it), read from
    a FULLTREE reply: a `<SubTree>` continues in the next `<BehaviorTree>` block of its ID."""
    blocks = ET.fromstring(xml).findall("BehaviorTree")
    queued: dict[str, list[ET.Element]] = {}
    for block in blocks[1:]:
        queued.setdefault(block.get("ID"), []).append(block)
    out: dict[str, int] = {}

    def walk(element: ET.Element, parent: str) -> None:
        path = f"{parent}/{element.get('name')}" if parent else element.get("name")
        out[path] = int(element.get("_uid"))
        for child in queued[element.get("ID")].pop(0) if element.tag == "SubTree" else element:
            walk(child, path)

    walk(blocks[0][0], "")
    return out


def uids_by_path(client: Client) -> dict[str, int]:
    return fvtree_uids(client.full_tree())


# ---- the tree, the statuses, the blackboards -----------------------------------------------------
def test_the_full_tree_names_every_node_with_a_uid_and_its_path(assembly):
    run, client = assembly
    xml = client.full_tree()
    root = ET.fromstring(xml)
    assert root.tag == "root" and root.get("BTCPP_format") == "4"
    nodes = node_elements(xml)
    assert set(fvtree_uids(xml)) == set(run.tree.nodes)  # every node of the running tree
    uids = [int(e.get("_uid")) for e in nodes]
    assert len(set(uids)) == len(uids) == len(run.tree.nodes)
    assert all(e.get("_fullpath") for e in nodes)
    assert {e.get("_fullpath") for e in nodes if e.tag == "descend_until_contact"} == {"build/descend"}
    assert set(client.statuses()) == set(uids)  # the status buffer covers exactly these nodes
    assert len(client.tree_id) == 16
    # Each subtree instance is a block of its own, found from its <SubTree> by ID and the same _fullpath.
    blocks = {b.get("_fullpath"): b for b in root.findall("BehaviorTree")}
    subtree = next(e for e in nodes if e.tag == "SubTree")
    assert subtree.get("ID") == "prop_plate" and len(subtree) == 0
    assert blocks[subtree.get("_fullpath")].get("ID") == "prop_plate"
    assert root.find("TreeNodesModel/Action[@ID='descend_until_contact']") is not None


def test_the_statuses_follow_the_tree_tick_by_tick(assembly):
    run, client = assembly
    uid = uids_by_path(client)
    assert set(client.statuses().values()) == {0}  # nothing ran yet
    seen: dict[int, set[int]] = {}
    for tick in range(400):
        run.tick()
        if tick % 20:
            continue
        statuses = client.statuses()
        for path, node in run.tree.nodes.items():
            code = statuses[uid[path]]
            seen.setdefault(uid[path], set()).add(code)
            if node.status == Status.INVALID:
                assert code == 0 or code > 10  # idle, or idle after it ran (10 + that status)
            else:
                assert code == CODES[node.status], path
    locate = uid["main/assemble/elements/build/prop/pick/pick_once/locate"]
    assert {1, 2} <= seen[locate]  # running, then done
    assert 1 in seen[uid["main/assemble/elements/build/prop/pick/pick_once/scan"]]  # the scan ran for a while


def test_the_blackboards_decode_as_msgpack(assembly):
    run, client = assembly
    for _ in range(60):
        run.tick()
    boards = msgpack.unpackb(client.blackboards("architectural_assembly", "build", "nope"))
    assert set(boards) == {"architectural_assembly", "build"}  # unknown names left out
    tree_board = boards["architectural_assembly"]
    assert tree_board["/robot/pose"] == pytest.approx(list(Blackboard.storage["/robot/pose"]))
    assert tree_board["/task/element"]["id"] == Blackboard.storage["/task/element"]["id"]
    assert tree_board["/fv/left"]["finger"] == "left"
    assert boards["build"] == {"scan_step": 0.002, "descend_speed": 0.01, "grasp_force": 40.0,
                               "grasp_squeeze": 0.005, "regrasps": 1, "end_clearance": 0.02, "min_clarity": 5.0,
                               "min_top_width": 0.08, "scan_span": "0.0;1.0", "scan_speed": 0.03}


def test_transitions_are_recorded_as_the_transition_log_has_them(assembly):
    TICKS = 2000  # about a minute of cell time: the pick and the lift
    run, client = assembly
    uid = uids_by_path(client)
    for _ in range(30):
        run.tick()
    t0 = run.cell.clock.now()
    assert abs(client.start_recording() / 1e6 - time.time()) < 600  # wall time, microseconds
    start_tick = run.ticks
    for _ in range(TICKS):
        run.tick()
    client.stop_recording()
    recorded = client.transitions()
    for _ in range(30):
        run.tick()
    assert client.transitions() == []  # stopped: nothing more
    logged = [json.loads(line) for line in (run.run_dir / "transitions.jsonl").read_text().splitlines()]
    expected = [(round((r["t"] - t0) * 1e6), uid[r["node"]], CODES[Status[r["to"]]])
                for r in logged if start_tick <= r["tick"] < start_tick + TICKS]
    assert len(recorded) == len(expected) > 10
    # Within a tick the order differs (by uid here, children first in the log): compare sorted.
    for (usec, node, status), (want_usec, want_node, want_status) in zip(sorted(recorded), sorted(expected)):
        assert (node, status) == (want_node, want_status)
        assert abs(usec - want_usec) <= 1  # cell time since recording started
    assert [r[0] for r in recorded] == sorted(r[0] for r in recorded)


def test_bad_requests_get_btcpp_error_replies(assembly):
    _, client = assembly
    assert client.raw([b"\x02T"]) == [b"error", b"wrong request header"]
    with pytest.raises(ServerError, match="must be 2 parts message"):
        client.request("B")
    with pytest.raises(ServerError, match="Request not recognized"):
        client.request("N")
    with pytest.raises(ServerError, match="Request not recognized"):
        client.request("?")
    with pytest.raises(ServerError, match="Node ID not found"):
        client.request("R", json.dumps({"uid": 9999, "position": 0}).encode())
    assert client.full_tree().startswith("<root")  # the server goes on


@pytest.fixture(scope="module")
def btcpp(request):
    """The real BehaviorTree.CPP (tests/btcpp_library.py), or a skip saying why it cannot be built."""
    from btcpp_library import LibraryUnavailable
    from btcpp_library import build as build_library

    try:
        return build_library(Path(request.config.cache.mkdir("btcpp-stubs")))
    except LibraryUnavailable as exc:
        if os.environ.get("FVTREE_REQUIRE_BTCPP"):  # set by .ci/run where it must work
            pytest.fail(f"the real BehaviorTree.CPP cannot be built: {exc}")
        pytest.skip(f"the real BehaviorTree.CPP cannot be built here: {exc}")


TREES = sorted((ROOT / "trees").glob("*.yaml"))


@pytest.mark.parametrize("tree", TREES, ids=[t.stem for t in TREES])
def test_the_full_tree_is_what_btcpp_s_own_publisher_sends(btcpp, tree):
    """BT.CPP loads the exported file and writes it as its Groot2 publisher does: the same blocks
    (ID, _fullpath) in the same order, the same nodes (tag, name, _uid) in each, the same _fullpath
    where BT.CPP writes one (SubTree nodes), and every port of ours with BT.CPP's value (BT.CPP
    adds the ports left to their defaults)."""
    assert_same_full_tree(btcpp, tree)


def test_a_guard_s_full_tree_is_what_btcpp_s_own_publisher_sends(btcpp, tmp_path):
    """A guard is exported as a ReactiveSequence of its condition and its child: its condition
    (BT.CPP's node only) has a uid of its own there too."""
    tree = tmp_path / "guarded.yaml"
    tree.write_text("version: 1\nname: guarded\nroot:\n  sequence: top\n  memory: true\n  children:\n"
                    "    - guard: light\n      while: {key: /fv/left.slip, op: lt, value: 0.5}\n"
                    "      child: {skill: move_to, name: a, params: {offset: [0.0, 0.0, 0.01]}}\n"
                    "    - {skill: move_to, name: b, params: {offset: [0.0, 0.0, 0.01]}}\n")
    assert_same_full_tree(btcpp, tree)


def assert_same_full_tree(btcpp, tree: Path) -> None:
    from assembly.interop.btcpp import export_tree
    from assembly.interop.groot2.tree_xml import monitor_tree

    ours = ET.fromstring(monitor_tree(load_tree(tree)).xml)
    theirs = ET.fromstring(btcpp.fulltree(export_tree(tree, tree.parent)))
    blocks = [(b.get("ID"), b.get("_fullpath")) for b in theirs.findall("BehaviorTree")]
    assert [(b.get("ID"), b.get("_fullpath")) for b in ours.findall("BehaviorTree")] == blocks
    for mine, real in zip(ours.findall("BehaviorTree"), theirs.findall("BehaviorTree")):
        mine_nodes, real_nodes = list(mine.iter())[1:], list(real.iter())[1:]
        assert [(e.tag, e.get("_uid")) for e in mine_nodes] == [(e.tag, e.get("_uid")) for e in real_nodes]
        for m, r in zip(mine_nodes, real_nodes):
            assert m.get("name") == r.get("name", m.get("name"))  # BT.CPP writes no name on a SubTree
            if r.get("_fullpath") is not None:
                assert m.get("_fullpath") == r.get("_fullpath")
            ports = {k: v for k, v in m.attrib.items() if k not in ("name", "ID", "_uid", "_fullpath")}
            assert ports.items() <= r.attrib.items(), m.get("_fullpath")


# ---- breakpoints -----------------------------------------------------------------------------------
def hook(uid: int, mode: int = 0, desired: str = "SKIPPED", position: int = 0) -> bytes:
    return json.dumps({"uid": uid, "position": position, "mode": mode, "enabled": True, "once": False,
                       "desired_status": desired}).encode()


def in_background(run: Run) -> tuple[threading.Thread, dict]:
    out: dict = {}
    thread = threading.Thread(target=lambda: out.setdefault("result", run.loop()), daemon=True)
    thread.start()
    return thread, out


def test_a_breakpoint_pauses_the_tree_and_holds_the_cell_still_until_unlocked(tmp_path):
    run, client = monitored(HOLD, tmp_path)
    try:
        uid = uids_by_path(client)
        lift = uid["hold_demo/lift"]
        client.request("I", hook(lift))
        assert json.loads(client.request("D")[0]) == [{"enabled": True, "uid": lift, "mode": 0, "once": False,
                                                       "desired_status": "SKIPPED", "position": 0}]
        thread, out = in_background(run)
        assert client.breakpoint_reached() == lift
        paused_at, statuses = run.cell.clock.now(), client.statuses()
        assert statuses[uid["hold_demo/grasp"]] == 2 and statuses[lift] == 0  # grasped; the lift not begun
        thread.join(0.5)  # a while paused: the tick waits and the simulated cell does not step
        assert thread.is_alive() and run.cell.clock.now() == paused_at and client.statuses() == statuses
        client.request("U", json.dumps({"uid": lift, "position": 0, "desired_status": "SKIPPED",
                                        "remove_when_done": True}).encode())
        thread.join(300)
        assert out["result"].status == "SUCCESS"
        assert run.cell.clock.now() > paused_at + 8  # lifted and held for its 8 s
        assert json.loads(client.request("D")[0]) == []  # removed when done
    finally:
        client.close()
        run.close()


def test_a_client_gone_silent_lets_a_paused_tree_go_on(tmp_path, monkeypatch):
    """BT.CPP's heartbeat: no request for a while disables the hooks, so a vanished Groot2 does not
    leave the cell paused for ever."""
    run, client = monitored(HOLD, tmp_path)
    try:
        lift = uids_by_path(client)["hold_demo/lift"]
        client.request("I", hook(lift))
        thread, out = in_background(run)
        assert client.breakpoint_reached() == lift
        monkeypatch.setattr("assembly.interop.groot2.server.MAX_SILENCE", 0.2)  # 5 s in BT.CPP and here
        thread.join(300)  # the client asks nothing more
        assert out["result"].status == "SUCCESS"
        assert not json.loads(client.request("D")[0])[0]["enabled"]  # disabled; this request revives them
        assert json.loads(client.request("D")[0])[0]["enabled"]
    finally:
        client.close()
        run.close()


def test_an_estop_while_paused_stops_the_run(tmp_path):
    run, client = monitored(HOLD, tmp_path)
    try:
        lift = uids_by_path(client)["hold_demo/lift"]
        client.request("I", hook(lift))
        thread, out = in_background(run)
        client.breakpoint_reached()
        (run.run_dir / "ESTOP").touch()  # the run's checks go on while the tree is paused
        thread.join(300)
        result = out["result"]
        assert result.status == "ESTOP" and result.where == "hold_demo/lift"  # the node the pause was at
        assert not run.cell.arm.is_moving()
    finally:
        client.close()
        run.close()


def test_a_replace_hook_gives_the_node_its_result_without_running_it(tmp_path):
    run, client = monitored(HOLD, tmp_path)
    try:
        lift = uids_by_path(client)["hold_demo/lift"]
        client.request("I", hook(lift, mode=1, desired="FAILURE"))
        result = run.loop()
        assert result.status == "FAILURE" and result.where == "hold_demo/lift"
        assert run.tree.nodes["hold_demo/lift"].status == Status.FAILURE
        assert run.tree.nodes["hold_demo/hold"].status == Status.INVALID  # the sequence stopped there
        log = (run.run_dir / "transitions.jsonl").read_text()
        assert '"node": "hold_demo/lift", "from": "INVALID", "to": "RUNNING"' not in log  # never ran
    finally:
        client.close()
        run.close()


UNDER_PARALLEL = """version: 1
name: under_parallel
cell: {tick_hz: 30, scene: hold}
root:
  sequence: main
  memory: true
  children:
    - parallel: both
      policy: all
      synchronise: true
      children:
        - {skill: move_to, name: up, params: {offset: [0.0, 0.0, 0.02], speed: 0.05}}
        - {condition: open, key: /gripper/width, op: gt, value: 0.0}
"""


def test_hooks_reach_nodes_that_py_trees_ticks_through_generators(tmp_path):
    """py_trees' parallel ticks its children with their generator `tick`, not `tick_once`."""
    tree = tmp_path / "under_parallel.yaml"
    tree.write_text(UNDER_PARALLEL)
    run, client = monitored(tree, tmp_path)
    try:
        uid = uids_by_path(client)
        client.request("I", hook(uid["main/both/up"]))
        client.request("I", hook(uid["main/both/open"], mode=1, desired="FAILURE", position=1))  # after its tick
        thread, out = in_background(run)
        assert client.breakpoint_reached() == uid["main/both/up"]
        client.request("U", json.dumps({"uid": uid["main/both/up"], "position": 0, "desired_status": "SUCCESS",
                                        "remove_when_done": False}).encode())
        thread.join(300)
        assert out["result"].status == "FAILURE"  # the condition's result replaced after it ran
        assert run.tree.nodes["main/both/open"].status == Status.FAILURE
        assert run.cell.clock.now() < 0.2  # `up` never moved: its result was given at the breakpoint
    finally:
        client.close()
        run.close()


def test_hooks_are_refused_with_the_reason_where_the_cell_cannot_hold_still():
    from assembly.interop.groot2 import start_monitor

    doc = load_tree(HOLD)
    port = free_port_pair()
    reason = "breakpoints are refused on a real or emulated cell"
    monitor = start_monitor(doc, build(doc).nodes, lambda: 0.0, port, hooks_refused=reason)
    client = Client(port)
    try:
        with pytest.raises(ServerError, match=reason):
            client.request("I", hook(1))
        assert json.loads(client.request("D")[0]) == []
    finally:
        client.close()
        monitor.close()


def test_the_bytes_are_btcpp_s():
    """Header, status and transition layouts, byte for byte as groot2_protocol.h lays them out."""
    from assembly.interop.groot2 import protocol

    header = protocol.Header.decode(bytes([2, ord("S"), 0x78, 0x56, 0x34, 0x12]))
    assert (header.protocol, header.type, header.request_id) == (2, ord("S"), 0x12345678)
    assert protocol.reply_header(header, bytes(range(16))) == bytes([2, ord("S"), 0x78, 0x56, 0x34, 0x12, *range(16)])
    assert protocol.encode_statuses([(1, 2), (0x0102, 13)]) == bytes([1, 0, 2, 2, 1, 13])
    assert protocol.encode_transitions([(0x010203040506, 7, 1)]) == bytes([6, 5, 4, 3, 2, 1, 7, 0, 1])
    assert protocol.decode_transitions(bytes([6, 5, 4, 3, 2, 1, 7, 0, 1])) == [(0x010203040506, 7, 1)]
    with pytest.raises(protocol.ProtocolError, match="wrong request header"):
        protocol.Header.decode(b"\x02S")
    hooks = protocol.parse_hooks(b'[{"uid": 3, "position": 1, "mode": 1, "enabled": true, "once": true,'
                                 b' "desired_status": "FAILURE"}]')
    assert hooks[0].to_json() == {"enabled": True, "uid": 3, "mode": 1, "once": True, "desired_status": "FAILURE",
                                  "position": 1}
    with pytest.raises(protocol.ProtocolError, match="needs the field 'uid'"):
        protocol.parse_hooks(b'{"position": 0}')


# ---- the command line ------------------------------------------------------------------------------
def test_groot2_option_defaults_to_port_1667_on_this_machine_only_and_realtime():
    args = parser().parse_args(["run", str(HOLD), "--groot2"])
    options = run_options(args)
    assert options.groot2 == ("127.0.0.1", 1667) and options.realtime
    args = parser().parse_args(["run", str(HOLD), "--groot2", "5555", "--groot2-address", "0.0.0.0", "--speed", "max"])
    options = run_options(args)
    assert options.groot2 == ("0.0.0.0", 5555) and not options.realtime
    assert not run_options(parser().parse_args(["run", str(HOLD)])).realtime


def test_a_taken_port_is_a_clear_error(tmp_path, capsys):
    port = free_port_pair()
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", port))
        taken.listen()
        code = main(["run", str(HOLD), "--groot2", str(port), "--runs-dir", str(tmp_path), "--no-record"])
    assert code == 2
    assert f"--groot2: cannot listen on 127.0.0.1:{port}" in capsys.readouterr().err


def test_a_taken_publisher_port_is_a_clear_error_too():
    from assembly.interop.groot2 import Groot2Error, start_monitor

    doc = load_tree(HOLD)
    port = free_port_pair()
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", port + 1))
        taken.listen()
        with pytest.raises(Groot2Error, match=f"cannot listen on 127.0.0.1:{port + 1}"):
            start_monitor(doc, build(doc).nodes, lambda: 0.0, port)
    start_monitor(doc, build(doc).nodes, lambda: 0.0, port).close()  # both ports were freed again


def test_missing_libraries_are_a_clear_error(monkeypatch):
    from assembly.interop.groot2 import Groot2Error, start_monitor

    monkeypatch.setitem(sys.modules, "zmq", None)
    doc = load_tree(HOLD)
    with pytest.raises(Groot2Error, match="needs the Python packages pyzmq and msgpack") as caught:
        start_monitor(doc, build(doc).nodes, lambda: 0.0, free_port_pair())
    assert "pip install" in str(caught.value)


# ---- btview: a third-party Groot2 monitor ----------------------------------------------------------
btview = pytest.importorskip("btview", reason="btview (PyPI, in the [test] extra) is not installed")


def test_btview_reads_the_tree_statuses_and_blackboard(assembly):
    from btview.client import Groot2Client
    from btview.model import NodeStatus

    run, client = assembly
    for _ in range(200):
        run.tick()
    viewer = Groot2Client("127.0.0.1", client.port, timeout_ms=60_000)
    try:
        tree = viewer.fetch_tree()
        assert tree.size == len(run.tree.nodes)
        by_uid = {node.uid: node for node in tree.walk()}
        uid = uids_by_path(client)
        assert set(by_uid) == set(uid.values())
        assert by_uid[uid["main/assemble/elements/build/prop/pick/pick_once/scan"]].registration == "vis_scan"
        statuses = viewer.poll().statuses
        for path, node in run.tree.nodes.items():
            if node.status != Status.INVALID:
                assert statuses[uid[path]].status == NodeStatus(CODES[node.status]), path
        board = viewer.fetch_blackboard(["architectural_assembly"])
        assert board["architectural_assembly"]["/gripper/width"] == pytest.approx(Blackboard.storage["/gripper/width"])
    finally:
        viewer.close()


def btview_cli(*args: str) -> subprocess.CompletedProcess:
    exe = shutil.which("btview", path=str(Path(sys.executable).parent)) or shutil.which("btview")
    command = [exe] if exe else [sys.executable, "-m", "btview"]
    return subprocess.run([*command, *args], check=False, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "NO_COLOR": "1", "COLUMNS": "160"})


@pytest.mark.slow
def test_btview_watches_a_live_fvtree_run(tmp_path):
    port = free_port_pair()
    fvtree = subprocess.Popen([sys.executable, "-m", "assembly.cli", "run", str(ASSEMBLY), "--groot2", str(port),
                               "--runs-dir", str(tmp_path), "--no-record", "--no-plots"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    client = Client(port)
    try:
        uid = uids_by_path(client)  # waits for the server (the run's start-up)
        deadline = time.monotonic() + 120.0  # the server answers before the first tick (set-up, a loaded machine)
        while True:
            snapshot = btview_cli("snapshot", "--port", str(port), "--ascii", "--uid", "--no-legend", "--timeout", "30")
            assert snapshot.returncode == 0, snapshot.stderr
            if "RUNNING" in snapshot.stdout or time.monotonic() > deadline:
                break
            time.sleep(0.5)
        assert "descend_until_contact" in snapshot.stdout or "descend" in snapshot.stdout
        assert "elements" in snapshot.stdout and "RUNNING" in snapshot.stdout
        info = btview_cli("info", "--port", str(port), "--timeout", "30", "--samples", "3")
        assert info.returncode == 0, info.stderr
        assert f"{len(uid)}" in info.stdout and "Groot2" in info.stdout
        board = btview_cli("blackboard", "architectural_assembly", "--json", "--port", str(port), "--timeout", "30")
        assert board.returncode == 0, board.stderr
        assert "/robot/pose" in json.loads(board.stdout)["architectural_assembly"]
        print(snapshot.stdout, info.stdout, sep="\n")  # what btview showed (pytest -s)
    finally:
        client.close()
        fvtree.send_signal(signal.SIGTERM)
        out, err = fvtree.communicate(timeout=120)
    assert fvtree.returncode == 1, err  # halted like Ctrl-C
    assert "HALTED" in out
