# r: compas_eve>=2.4
"""fvtree design view: a Grasshopper (Rhino 8) Python 3 component that shows one cell's plan and
as-built elements coloured by status, live, and sends a change of a planned element.

Set up (see README.md next to this file): a Python 3 Script component in Rhino 8 with
  inputs   broker (str, e.g. 127.0.0.1:1883), cell (str, the `--cell-name` of the run),
           on (bool), element (str, an element id), plane (Plane: its new planned frame),
           send (bool, a Button)
  outputs  boxes (Brep list), colours (Colour list), labels (str list), frames (Plane list), log (str)
Wire boxes and colours into a Custom Preview component. The `# r:` line above installs compas_eve
(and compas) into Rhino's Python the first time the component runs.
"""

import json

import Grasshopper
import Rhino
import scriptcontext as sc
import System
from compas_eve import Message, Publisher, Subscriber, Topic
from compas_eve.mqtt import MqttTransport
from compas_rhino.conversions import box_to_rhino, frame_to_rhino_plane, plane_to_compas_frame

COLOURS = {"planned": (180, 180, 180), "picking": (255, 200, 0), "placing": (255, 120, 0),
           "placed": (0, 170, 80), "failed": (220, 0, 0)}  # as examples/design_client.py
DESIGN_FIELDS = ("plate", "size", "mass", "pick_frame")  # what a change sends again besides the new frame
KEY = "fvtree_design_view"


def _state(broker, cell):
    """One connection and subscription per component and (broker, cell), kept across solutions."""
    state = sc.sticky.get(KEY)
    if state and state["where"] == (broker, cell):
        return state
    if state:
        state["transport"].close()
    host, _, port = broker.partition(":")
    transport = MqttTransport(host, int(port or 1883))
    transport.client.suppress_exceptions = True  # a message that fails to decode must not deafen the component
    state = {"where": (broker, cell), "transport": transport, "plan": None, "answers": []}
    component = ghenv.Component  # noqa: F821 - given by Grasshopper

    def refresh():
        Rhino.RhinoApp.InvokeOnUiThread(System.Action(lambda: component.ExpireSolution(True)))

    def on_plan(graph):
        if not hasattr(graph, "nodes"):  # not a COMPAS Graph (a bad retained plan): keep the last good one
            state["answers"] = (state["answers"] + ["dropped a plan that is not a COMPAS Graph"])[-5:]
            return
        state["plan"] = graph
        refresh()

    def on_answer(message):
        state["answers"] = (state["answers"] + [str(message)])[-5:]
        refresh()

    Subscriber(Topic(f"fvtree/{cell}/plan"), callback=on_plan, transport=transport).subscribe()
    for leaf in ("conflicts", "errors"):
        Subscriber(Topic(f"fvtree/{cell}/{leaf}"), callback=on_answer, transport=transport).subscribe()
    state["updates"] = Publisher(Topic(f"fvtree/{cell}/updates"), transport=transport)
    sc.sticky[KEY] = state
    return state


class DesignView(Grasshopper.Kernel.GH_ScriptInstance):
    def RunScript(self, broker, cell, on, element, plane, send):
        if not (on and broker and cell):
            return [], [], [], [], "off"
        state = _state(broker, cell)
        graph = state["plan"]
        boxes, colours, labels, frames = [], [], [], []
        if graph is not None:
            for key, attrs in graph.nodes(data=True):
                status = attrs.get("status", "planned") if attrs.get("kind") == "element" else "planned"
                boxes.append(box_to_rhino(attrs["box"]).ToBrep())
                colours.append(System.Drawing.Color.FromArgb(*COLOURS.get(status, (120, 120, 120))))
                load = attrs.get("measured_load")
                labels.append(f"{key} {status}" + ("" if load is None else f" {load:.1f} N"))
                frame = attrs.get("asbuilt_frame") or attrs.get("planned_frame") or attrs.get("frame")
                frames.append(frame_to_rhino_plane(frame) if frame else None)
        log = "\n".join(state["answers"]) or f"listening on fvtree/{cell}/#"
        if send and graph is not None and element in graph.node and plane is not None:
            attrs = graph.node_attributes(element)
            change = {k: attrs[k] for k in DESIGN_FIELDS if attrs.get(k) is not None}
            change.update(id=element, planned_frame=plane_to_compas_frame(plane))
            update_id = f"gh-{element}-{System.DateTime.Now.Ticks}"
            state["updates"].publish(Message(update=update_id, elements=[change]))
            log = f"sent {update_id} ({json.dumps({'element': element})})\n{log}"
        return boxes, colours, labels, frames, log
