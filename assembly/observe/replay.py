"""`fvtree view RUN_DIR`: serve a run's recordings with the Rerun web viewer on 127.0.0.1 (or open
the native viewer). A run directory from before recordings existed gets one built from what it
has: the transition log (tree statuses and transitions), the event log and the summary.

Serving is done by the `rerun` program that comes with rerun-sdk (it binds to 127.0.0.1 only);
the live view of `fvtree run --view` is the same program with no file, which the run streams to.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import rerun as rr

from assembly.observe.layout import default_blueprint
from assembly.observe.recorder import CHANGE_TIMELINE, NODE_RADIUS
from assembly.observe.tree_graph import tree_graph
from assembly.signals import sigterm_raises_terminated
from fvfiles.errors import FvtreeError

HOST = "127.0.0.1"
GRPC_PORT, WEB_PORT = 9876, 9090


@dataclass
class Viewer:
    """A running `rerun` viewer server: its process, the page to open and the gRPC URL to send to."""

    process: subprocess.Popen
    page: str
    grpc: str

    def stop(self) -> None:
        """End the server (and wait for it)."""
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def rerun_program() -> list[str]:
    """The `rerun` viewer program that rerun-sdk installs: the binary itself, not its Python
    launcher, so that stopping the process stops the server."""
    import rerun_cli

    binary = Path(rerun_cli.__file__).with_name("rerun")
    return [str(binary)] if binary.is_file() else [sys.executable, "-m", "rerun_cli"]


def start_viewer(files: list[Path], web_port: int = WEB_PORT, grpc_port: int = GRPC_PORT, web: bool = True,
                 timeout: float = 60.0) -> Viewer:
    """Serve `files` (none: wait for a live stream) on 127.0.0.1, with the web viewer (`web`) or the
    native one; returns once the server listens (FvtreeError if it does not within `timeout` s)."""
    command = [*rerun_program(), "--bind", HOST, "--port", str(grpc_port), "--hide-welcome-screen"]
    if web:
        command += ["--serve-web", "--web-viewer-port", str(web_port)]
    command += [str(f) for f in files]
    log = tempfile.TemporaryFile()  # noqa: SIM115 - the server writes to it for as long as it runs
    process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                               env={**os.environ, "RERUN_ANALYTICS": "0"})
    grpc = f"rerun+http://{HOST}:{grpc_port}/proxy"
    page = f"http://{HOST}:{web_port}/?url={grpc.replace(':', '%3A').replace('/', '%2F').replace('+', '%2B')}"
    viewer = Viewer(process, page if web else "", grpc)
    deadline = time.monotonic() + timeout
    while not _listening(grpc_port) or (web and not _listening(web_port)):
        if process.poll() is not None or time.monotonic() > deadline:
            viewer.stop()
            log.seek(0)
            tail = log.read().decode(errors="replace")[-800:]
            raise FvtreeError(f"the rerun viewer did not start on {HOST}:{grpc_port}"
                              + (f"/{web_port}" if web else "") + f": {tail.strip() or 'no output'}",
                              hint="is another viewer using these ports? choose others with --port/--web-port")
        time.sleep(0.1)
    return viewer


def _listening(port: int) -> bool:
    import socket

    with socket.socket() as s:
        s.settimeout(0.5)
        return s.connect_ex((HOST, port)) == 0


def run_recordings(run_dir: Path) -> list[Path]:
    """A run directory's recordings (one per session of the run), oldest first; for a run from
    before recordings, one built from its logs (in a temporary directory)."""
    if not run_dir.is_dir():
        raise FvtreeError("no such run directory", str(run_dir))
    files = sorted(run_dir.glob("recording*.rrd"), key=lambda p: (len(p.name), p.name))
    if files:
        return files
    if not (run_dir / "transitions.jsonl").is_file():
        raise FvtreeError("not a run directory: no recording.rrd and no transitions.jsonl", str(run_dir),
                          hint="give a directory that `fvtree run` made, under runs/")
    out = Path(tempfile.mkdtemp(prefix="fvtree-view-")) / "from_logs.rrd"
    return [recording_from_logs(run_dir, out)]


def recording_from_logs(run_dir: Path, out: Path) -> Path:
    """A recording of what an old run directory holds: the tree graph (when its tree file can still
    be read) coloured by the transition log, the transitions, the events and the summary."""
    from assembly.language.reader import load_tree  # the tree file of the run, if it is still there

    stream = rr.RecordingStream("fvtree", recording_id=f"{run_dir.name}/from_logs")
    stream.set_sinks(rr.FileSink(str(out)), default_blueprint=default_blueprint())
    stream.set_log_time_enabled(False)
    stream.set_log_tick_enabled(False)
    transitions = _json_lines(run_dir / "transitions.jsonl")
    graph = None
    try:
        run = json.loads((run_dir / "run.json").read_text())
        graph = tree_graph(load_tree(run["tree_file"]).root)
    except (OSError, ValueError, KeyError, FvtreeError):
        pass  # no graph: the transitions and events still show
    statuses = ["INVALID"] * len(graph.paths) if graph else []
    if graph:
        stream.log("tree/graph", rr.GraphNodes(graph.paths, labels=graph.labels, positions=graph.positions,
                                               radii=NODE_RADIUS, show_labels=True), static=True)
        stream.set_time("tick", sequence=0)
        stream.set_time("cell_time", duration=0.0)
        stream.log("tree/graph", rr.GraphNodes(graph.paths, colors=graph.colours(statuses)))
        stream.log("tree/graph", rr.GraphEdges(graph.edges, graph_type="directed"), static=True)
    order = {p: i for i, p in enumerate(graph.paths)} if graph else {}
    for change, record in enumerate(transitions):
        stream.set_time("tick", sequence=int(record.get("tick", 0)))
        stream.set_time("cell_time", duration=float(record.get("t", 0.0)))
        stream.set_time(CHANGE_TIMELINE, sequence=change)  # as the recorder numbers status changes
        node, to = record.get("node", "?"), record.get("to", "?")
        feedback = record.get("feedback") or ""
        stream.log("tree/status", rr.AnyValues(node=node, status=to, feedback=feedback))
        stream.log("tree/transitions", rr.TextLog(f"{node}: {record.get('from')} -> {to}"
                                                  + (f" ({feedback})" if feedback else ""),
                                                  level="WARN" if to == "FAILURE" else "INFO"))
        stream.disable_timeline(CHANGE_TIMELINE)
        if graph and node in order:  # (order is empty without a graph)
            statuses[order[node]] = to
            stream.log("tree/graph", rr.GraphNodes(graph.paths, colors=graph.colours(statuses)))
    last = transitions[-1] if transitions else {}
    stream.set_time("tick", sequence=int(last.get("tick", 0)))
    stream.set_time("cell_time", duration=float(last.get("t", 0.0)))
    for event in _json_lines(run_dir / "events.jsonl"):  # stamped by wall clock only: shown at the end
        details = {k: v for k, v in event.items() if k not in ("time", "event", "traceback")}
        stream.log("events", rr.TextLog(f"{event.get('event')} {json.dumps(details)}"))
    summary = run_dir / "summary.json"
    if summary.is_file():
        stream.log("info", rr.TextDocument(f"```json\n{summary.read_text()}\n```", media_type="text/markdown"),
                   static=True)
    stream.flush()
    stream.disconnect()
    return out


def _json_lines(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    records = []
    for line in path.read_text().splitlines():
        try:
            record = json.loads(line)
        except ValueError:
            continue
        if isinstance(record, dict):
            records.append(record)
    return records


def view(run_dir: Path, web: bool = True, web_port: int = WEB_PORT, grpc_port: int = GRPC_PORT,
         say=lambda line: print(line, flush=True)) -> int:
    """Serve a run until Ctrl-C; the web viewer's address is printed."""
    files = run_recordings(run_dir)
    if not web and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise FvtreeError("no display for the native viewer", str(run_dir), hint="drop --native to use the web viewer")
    viewer = start_viewer(files, web_port, grpc_port, web)
    try:
        with sigterm_raises_terminated():
            say(f"viewing {', '.join(str(f) for f in files)}")
            if web:
                say(f"open {viewer.page}  (Ctrl-C to stop)")
            return viewer.process.wait()
    except KeyboardInterrupt:
        return 0
    finally:
        viewer.stop()
        if files and files[0].parent.name.startswith("fvtree-view-"):
            shutil.rmtree(files[0].parent, ignore_errors=True)


@contextmanager
def live_view(enabled: bool, say=print) -> Iterator[Viewer | None]:
    """For `fvtree run --view`: a web viewer on 127.0.0.1 for the run to stream to (None when not
    `enabled`); after the run it keeps serving until Ctrl-C, so the run can still be looked at."""
    if not enabled:
        yield None
        return
    viewer = start_viewer([])
    say(f"live view: open {viewer.page}")
    try:
        yield viewer
        say(f"the run has ended; the live view stays at {viewer.page} until Ctrl-C")
        with sigterm_raises_terminated():
            viewer.process.wait()
    except KeyboardInterrupt:
        pass
    finally:
        viewer.stop()
