"""A designer's side of the fvtree design link in plain Python, with compas_eve only (no fvtree):
it follows one cell's plan and element statuses, prints the elements by status with their as-built
frames and measured loads, and can send a design change. The Grasshopper component in
docs/grasshopper/ does the same inside Rhino 8.

    python examples/design_client.py --broker mqtt://127.0.0.1:1883 --cell architectural_assembly
    python examples/design_client.py --broker ... --cell ... --send change.json --watch 60

change.json: {"update": "u1", "elements": [{"id": "E3", "plate": "P1", "size": [0.435, 0.04, 0.04],
              "pick_pose": [0.3, -0.6, 0.02, 0, 0, 0]}], "edges": [{"source": "E1", "target": "E3"}]}

On a secured broker (README, "A secured broker for a lab"): log in as the lab's designer user with
FVTREE_MQTT_USERNAME and FVTREE_MQTT_PASSWORD in the environment, and for mqtts:// give the lab's
CA with --ca. compas_eve's own transport connects in its constructor, before a login can be set,
so `LoginTransport` below sets it first. Whatever arrives, the client survives it: the plan is
checked before it is decoded (a bad one is dropped and listed in `dropped`), and a message that
fails to decode elsewhere is logged by paho instead of stopping its network thread.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import threading
import time
from urllib.parse import urlsplit

import compas
import paho.mqtt.client as mqtt
from compas.datastructures import Graph
from compas_eve import Message, Publisher, Subscriber, Topic
from compas_eve.mqtt import MqttTransport
from paho.mqtt.enums import CallbackAPIVersion

log = logging.getLogger("design_client")
MAX_PLAN_BYTES = 4_000_000

DESIGN_FIELDS = ("plate", "size", "mass", "pick_frame")  # sent again with a change, as in Grasshopper
COLOURS = {"planned": (180, 180, 180), "picking": (255, 200, 0), "placing": (255, 120, 0),
           "placed": (0, 170, 80), "failed": (220, 0, 0)}  # RGB by status, as the Grasshopper example draws


class LoginTransport(MqttTransport):
    """compas_eve's MQTT transport that logs in (user name, password) and, for mqtts://, speaks
    TLS before it connects; a callback that raises is logged, never fatal to the network thread."""

    def __init__(self, broker: str, username: str | None = None, password: str | None = None,
                 ca: str | None = None):
        url = urlsplit(broker)
        super(MqttTransport, self).__init__()  # compas_eve's Transport base, without its early connect
        self.host, self.port = url.hostname, url.port or (8883 if url.scheme == "mqtts" else 1883)
        self._is_connected = False
        self._local_callbacks = {}
        self.client = mqtt.Client(callback_api_version=CallbackAPIVersion.VERSION1)
        self.client.suppress_exceptions = True
        self.client.on_connect = self._on_connect
        if username:
            self.client.username_pw_set(username, password)
        if url.scheme == "mqtts":
            self.client.tls_set(ca_certs=ca)
        self.client.connect(self.host, self.port)
        self.client.loop_start()

    def _on_connect(self, client, userdata, flags, rc) -> None:
        if rc != 0:
            log.error("the broker refused the connection: %s", mqtt.connack_string(rc))
            return
        super()._on_connect(client, userdata, flags, rc)


class DesignClient:
    """Follows `fvtree/CELL/{plan,status,events,conflicts,errors}` and sends to `fvtree/CELL/updates`."""

    def __init__(self, broker: str, cell: str, transport: MqttTransport | None = None):
        self.transport = transport or LoginTransport(broker, os.environ.get("FVTREE_MQTT_USERNAME"),
                                                     os.environ.get("FVTREE_MQTT_PASSWORD"))
        self.transport.client.suppress_exceptions = True  # a message that fails to decode must not deafen it
        self.cell = cell
        self.plan: Graph | None = None
        self.dropped: list[str] = []  # why messages were dropped unread
        self.statuses: list[Message] = []
        self.events: list[Message] = []
        self.conflicts: list[Message] = []
        self.errors: list[Message] = []
        self._lock = threading.Lock()
        plan_topic = f"fvtree/{cell}/plan"  # read raw: checked before it is decoded
        self.transport.client.message_callback_add(plan_topic, self._on_plan)
        self.transport.on("ready", lambda **_: self.transport.client.subscribe(plan_topic, qos=1))  # each connect
        if self.transport._is_connected:
            self.transport.client.subscribe(plan_topic, qos=1)
        for leaf, callback in (("status", self.statuses.append),
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

    def _on_plan(self, client, userdata, message) -> None:
        """The retained plan, decoded only once it looks like a COMPAS Graph; else dropped."""
        try:
            if len(message.payload) > MAX_PLAN_BYTES:
                raise ValueError(f"{len(message.payload)} bytes")
            data = json.loads(message.payload)
            graph = data.get("data") if isinstance(data, dict) else None
            if (not isinstance(graph, dict) or data.get("dtype") != "compas.datastructures/Graph"
                    or not isinstance(graph.get("node"), dict) or not isinstance(graph.get("edge"), dict)):
                raise TypeError("not a COMPAS Graph")
            plan = compas.json_loads(message.payload.decode())
            if not isinstance(plan, Graph):
                raise TypeError("not a COMPAS Graph")
        except Exception as exc:  # noqa: BLE001 - whatever it is, it is dropped, and the client goes on
            with self._lock:
                self.dropped.append(f"plan: {exc}")
            return
        with self._lock:
            self.plan = plan

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
    p.add_argument("--broker", required=True, help="mqtt://HOST:PORT or mqtts://HOST:PORT")
    p.add_argument("--ca", help="with mqtts://: the lab's CA certificate (default: the system's)")
    p.add_argument("--cell", required=True, help="the cell's name (fvtree run --cell-name)")
    p.add_argument("--send", help="a JSON file holding one design change to send")
    p.add_argument("--watch", type=float, default=3.0, help="seconds to listen before printing (default: 3)")
    args = p.parse_args(argv)
    client = DesignClient(args.broker, args.cell, LoginTransport(
        args.broker, os.environ.get("FVTREE_MQTT_USERNAME"), os.environ.get("FVTREE_MQTT_PASSWORD"), args.ca))
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
