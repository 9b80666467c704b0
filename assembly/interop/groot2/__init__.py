"""A running tree served to Groot2 over BehaviorTree.CPP's monitor protocol (`fvtree run --groot2`):
the bytes of the protocol (`protocol`), the tree as Groot2 reads it (`tree_xml`), the blackboards
(`blackboard`), breakpoints (`breakpoints`) and the ZeroMQ server (`server`). pyzmq and msgpack are
needed only here, and loaded only when a run asks for the monitor."""

from __future__ import annotations

import socket
from collections.abc import Callable
from typing import TYPE_CHECKING

import py_trees

from assembly.language.reader import TreeDocument
from fvfiles.errors import FvtreeError

if TYPE_CHECKING:
    from assembly.interop.groot2.server import Groot2Monitor

DEFAULT_PORT = 1667
INSTALL_HINT = "install them with: pip install 'pyzmq>=25' 'msgpack>=1.0' (or the project's [groot2] extra)"


class Groot2Error(FvtreeError):
    """The Groot2 monitor cannot start: its libraries are missing, its ports taken, or the tree has
    no BT.CPP spelling."""


def start_monitor(doc: TreeDocument, nodes: dict[str, py_trees.behaviour.Behaviour], now: Callable[[], float],
                  port: int = DEFAULT_PORT, host: str = "127.0.0.1",
                  hooks_refused: str | None = None) -> Groot2Monitor:
    """Serve the run of `doc` (its built `nodes` by path, the cell clock `now`) on `host`:`port`
    (REP) and `port`+1 (PUB); Groot2Error if that cannot be done."""
    try:
        import msgpack  # noqa: F401 - the blackboards' encoding
        import zmq  # noqa: F401
    except ImportError as exc:
        raise Groot2Error(f"--groot2 needs the Python packages pyzmq and msgpack ({exc})", hint=INSTALL_HINT) from None
    from assembly.errors import TreeErrors
    from assembly.interop.groot2.server import Groot2Monitor
    from assembly.interop.groot2.tree_xml import monitor_tree

    try:
        tree = monitor_tree(doc)
    except TreeErrors as exc:
        raise Groot2Error(f"--groot2: the tree has no BT.CPP XML for Groot2: {exc}", doc.path) from None
    return Groot2Monitor(tree, nodes, now, port, host, hooks_refused)


def free_port_pair() -> int:
    """A port P with P and P + 1 both free on 127.0.0.1, for a monitor that binds both (tests, benches)."""
    for _ in range(50):
        with socket.socket() as a:
            a.bind(("127.0.0.1", 0))
            port = a.getsockname()[1]
            if port >= 65535:
                continue
            with socket.socket() as b:
                try:
                    b.bind(("127.0.0.1", port + 1))
                except OSError:
                    continue
        return port
    raise RuntimeError("no two free consecutive ports on 127.0.0.1")
