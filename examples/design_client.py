"""A designer's side of the fvtree design link in plain Python, with compas_eve only (no fvtree):
it follows one cell's plan and element statuses, prints the elements by status with their as-built
frames and measured loads, and can send a design change. The Grasshopper component in
docs/grasshopper/ does the same inside Rhino 8.

    python examples/design_client.py --broker mqtt://127.0.0.1:1883 --cell architectural_assembly
    python examples/design_client.py --broker ... --cell ... --send change.json --watch 60

change.json: {"update": "u1", "elements": [{"id": "E3", "plate": "P1", "size": [0.435, 0.04, 0.04],
              "pick_pose": [0.3, -0.6, 0.02, 0, 0, 0]}], "edges": [{"source": "E1", "target": "E3"}]}
"""

from __future__ import annotations

import argparse
import json
import threading
import time
from urllib.parse import urlsplit

from compas.datastructures import Graph
from compas_eve import Message, Publisher, Subscriber, Topic
from compas_eve.mqtt import MqttTransport

DESIGN_FIELDS = ("plate", "size", "mass", "pick_frame")  # sent again with a change, as in Grasshopper
COLOURS = {"planned": (180, 180, 180), "picking": (255, 200, 0), "placing": (255, 120, 0),
           "placed": (0, 170, 80), "failed": (220, 0, 0)}  # RGB by status, as the Grasshopper example draws


class DesignClient:
    """Follows `fvtree/CELL/{plan,status,events,conflicts,errors}` and sends to `fvtree/CELL/updates`."""

    def __init__(self, broker: str, cell: str, transport: MqttTransport | None = None):
        url = urlsplit(broker)
        self.transport = transport or MqttTransport(url.hostname, url.port or 1883)
        self.cell = cell
        self.plan: Graph | None = None
        self.statuses: list[Message] = []
        self.events: list[Message] = []
        self.conflicts: list[Message] = []
        self.errors: list[Message] = []
        self._lock = threading.Lock()
        for leaf, callback in (("plan", self._on_plan), ("status", self.statuses.append),
                               ("events", self.events.append), ("conflicts", self.conflicts.append),
                               ("errors", self.errors.append)):
            Subscriber(Topic(f"fvtree/{cell}/{leaf}"), callback=self._locked(callback),
                       transport=self.transport).subscribe()
        self._updates = Publisher(Topic(f"fvtree/{cell}/updates"), transport=self.transport)

    def _locked(self, callback):
        def call(message):
            with self._lock:
                callback(message)
        return call

    def _on_plan(self, graph) -> None:
        self.plan = graph if isinstance(graph, Graph) else None

    def send(self, update: dict) -> None:
        """Send a design change (see the module docstring); answers come on conflicts/errors."""
        self._updates.publish(Message(**update))

    def change_planned(self, element: str, frame, update: str) -> None:
        """Move a planned element: send its design fields from the plan with a new planned frame
        (what the Grasshopper component's `send` button does)."""
        attrs = self.plan.node_attributes(element)
        change = {k: attrs[k] for k in DESIGN_FIELDS if attrs.get(k) is not None}
        self.send({"update": update, "elements": [{**change, "id": element, "planned_frame": frame}]})

    def elements(self) -> list[dict]:
        """The plan's elements: id, status, colour, as-built frame, measured load, cell, box."""
        if self.plan is None:
            return []
        return [{"id": key, "status": attrs.get("status", "planned"),
                 "colour": COLOURS.get(attrs.get("status", "planned")), "frame": attrs.get("asbuilt_frame"),
                 "load": attrs.get("measured_load"), "cell": attrs.get("cell"), "box": attrs.get("box")}
                for key, attrs in self.plan.nodes(data=True) if attrs.get("kind") == "element"]

    def report(self) -> str:
        lines = [f"{self.cell}: {len(self.statuses)} status messages, {len(self.conflicts)} conflicts, "
                 + f"{len(self.errors)} errors"]
        for e in self.elements():
            where = "" if e["frame"] is None else " at ({:.3f}, {:.3f}, {:.3f})".format(*e["frame"].point)
            load = "" if e["load"] is None else f", {e['load']:.2f} N"
            lines.append(f"  {e['id']:<6} {e['status']:<8}{where}{load}")
        for c in self.conflicts:
            lines.append(f"  conflict: update {c['update']}: {c['reason']}")
        for c in self.errors:
            lines.append(f"  error: update {c['update']}: {c['error']}")
        return "\n".join(lines)

    def close(self) -> None:
        self.transport.close()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--broker", required=True, help="mqtt://HOST:PORT")
    p.add_argument("--cell", required=True, help="the cell's name (fvtree run --cell-name)")
    p.add_argument("--send", help="a JSON file holding one design change to send")
    p.add_argument("--watch", type=float, default=3.0, help="seconds to listen before printing (default: 3)")
    args = p.parse_args(argv)
    client = DesignClient(args.broker, args.cell)
    time.sleep(0.5)  # let the retained plan arrive
    if args.send:
        with open(args.send) as f:
            client.send(json.load(f))
    time.sleep(args.watch)
    print(client.report())
    client.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
