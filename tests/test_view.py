"""`fvtree view` and the live view (assembly/observe/replay.py): the viewer server starts and serves
on 127.0.0.1, an old run directory without a recording opens what it has, a run streams live to a
viewer, and headless Chromium renders the web viewer.

The browser test needs Debian's `chromium`. Without it the test is skipped with the reason, unless
FVTREE_REQUIRE_BROWSER=1 (set by `.ci/run`, which installs Chromium when missing) makes it fail."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import urllib.request
from pathlib import Path

import cv2
import numpy as np
import pytest

from assembly.observe.readback import read_recording
from assembly.observe.replay import recording_from_logs, run_recordings, start_viewer
from assembly.run.options import RunOptions
from assembly.run.session import run_tree

ROOT = Path(__file__).resolve().parents[1]
ASSEMBLY = ROOT / "trees" / "assembly.yaml"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def short_run(tmp_path_factory) -> Path:
    """The first 20 s of the simulated assembly, recorded: its run directory."""
    summary = run_tree(str(ASSEMBLY), RunOptions(runs_dir=tmp_path_factory.mktemp("runs"), plots=False, quiet=True, max_time=20.0))
    return Path(summary.run_dir)


def _get(url: str) -> tuple[int, bytes]:
    with urllib.request.urlopen(url, timeout=30) as reply:
        return reply.status, reply.read()


def test_view_serves_the_recording_on_loopback(short_run):
    viewer = start_viewer(run_recordings(short_run), web_port=free_port(), grpc_port=free_port())
    try:
        assert viewer.page.startswith("http://127.0.0.1:")
        status, body = _get(viewer.page)
        assert status == 200 and b"rerun" in body.lower()
    finally:
        viewer.stop()
    assert viewer.process.returncode is not None


def test_fvtree_view_command_serves_until_terminated(short_run):
    web, grpc = free_port(), free_port()
    process = subprocess.Popen([sys.executable, "-m", "assembly.cli", "view", str(short_run), "--port", str(grpc),
                                "--web-port", str(web)], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               text=True)
    try:
        lines = [process.stdout.readline(), process.stdout.readline()]
        assert lines[0].startswith("viewing ") and "recording.rrd" in lines[0]
        assert lines[1].startswith(f"open http://127.0.0.1:{web}/")
        assert _get(f"http://127.0.0.1:{web}/")[0] == 200
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=60) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    with socket.socket() as s:  # the viewer server went with it
        assert s.connect_ex(("127.0.0.1", web)) != 0


def test_an_old_run_directory_opens_from_its_logs(short_run, tmp_path):
    old = tmp_path / "old_run"
    shutil.copytree(short_run, old, ignore=shutil.ignore_patterns("*.rrd"))
    files = run_recordings(old)
    assert len(files) == 1 and files[0].name == "from_logs.rrd"
    rec = read_recording(recording_from_logs(old, tmp_path / "again.rrd"))
    transitions = [json.loads(line) for line in (old / "transitions.jsonl").read_text().splitlines()]
    rows = [r for r in rec["tree/status"] if r["tick"] is not None]
    assert [(r["tick"], r["node"][0], r["status"][0]) for r in rows] == \
           [(t["tick"], t["node"], t["to"]) for t in transitions]
    assert {"tree/graph", "tree/transitions", "events"} <= set(rec)
    shutil.rmtree(files[0].parent)


def test_not_a_run_directory_is_a_located_error(tmp_path):
    from fvfiles.errors import FvtreeError

    with pytest.raises(FvtreeError, match="not a run directory"):
        run_recordings(tmp_path)


def _chromium_or_fail() -> None:
    if shutil.which("chromium") or shutil.which("chromium-browser"):
        return
    if os.environ.get("FVTREE_REQUIRE_BROWSER") == "1":
        pytest.fail("FVTREE_REQUIRE_BROWSER=1 but there is no Chromium to check that the web viewer renders")
    pytest.skip("no Chromium: apt-get install chromium to check that the web viewer renders "
                "(.ci/run installs it and then requires this test)")


def _colours(png: bytes) -> int:
    """Distinct colours in a screenshot: the viewer's loading screen has a handful (9 here), a
    rendered layout of panels, plots, graph and text has thousands (about 10 000 here)."""
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    return len(np.unique(image.reshape(-1, 3), axis=0))


def _rendered(png: bytes) -> bool:
    return _colours(png) > 1000


@pytest.mark.slow
def test_live_run_renders_in_headless_chromium(tmp_path):
    """A run streams live to a viewer server; headless Chromium opens the web viewer and renders it."""
    _chromium_or_fail()
    from assembly.observe.screenshot import screenshot

    viewer = start_viewer([], web_port=free_port(), grpc_port=free_port())
    try:
        summary = run_tree(str(ASSEMBLY), RunOptions(runs_dir=tmp_path, plots=False, quiet=True, max_time=15.0, live=viewer.grpc))
        assert summary.ticks > 0
        png = screenshot(viewer.page, tmp_path / "live.png", wait=120.0, ready=_rendered)
    finally:
        viewer.stop()
    assert _rendered(png.read_bytes()), f"the web viewer did not render within 120 s (see {png})"


def test_tree_graph_is_laid_out_top_down():
    from assembly.language.reader import load_tree
    from assembly.observe.tree_graph import X_STEP, Y_STEP, tree_graph

    doc = load_tree(ASSEMBLY)
    graph = tree_graph(doc.root)
    where = dict(zip(graph.paths, map(tuple, graph.positions)))
    assert graph.paths[0] == doc.root.path and where[doc.root.path][1] == 0.0
    children: dict[str, list[str]] = {}
    for parent, child in graph.edges:
        children.setdefault(parent, []).append(child)
        assert where[child][1] == where[parent][1] + Y_STEP  # one row further down
    for parent, kids in children.items():  # centred over its children
        xs = [where[k][0] for k in kids]
        assert where[parent][0] == pytest.approx((min(xs) + max(xs)) / 2)
    leaves = sorted(where[p][0] for p in graph.paths if p not in children)
    assert np.allclose(np.diff(leaves), X_STEP)  # one column per leaf, none shared
    assert len(graph.paths) == len(set(graph.paths)) == len(graph.edges) + 1
