"""One simulated cell of a coordinated build, as its own process (tests/test_coordinator.py):
the real design bridge, MQTT link, claim client and for_each_element, with each element's build
scripted (a few ticks of 20 ms, then placing and placed at the element's pick pose raised 1 m).

    python tests/coordinated_cell.py mqtt://127.0.0.1:PORT CELL RUN_DIR [--die-at ELEMENT]
        [--credentials FILE] [--build-ticks N] [--lost-after SECONDS]

--die-at: exit abruptly (no goodbye, no renewals) once ELEMENT is being built.
--credentials: log in and sign as the file says (assembly.design.link.security).
After every tick the design bridge's fault (a refused claim, a lost lease) is checked as the run's
stop policy checks it: the build is halted (the element's build stops where it is) and the cell
exits 3 with a `fault` event naming the reason."""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import py_trees
from py_trees.common import Access, Status

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from assembly.design.bridge import DesignBridge
from assembly.design.link.mqtt_bridge import attach
from assembly.design.link.security import LinkError, LinkSecurity
from assembly.design.model import DesignModel
from assembly.nodes.for_each_element import ForEachElement
from behaviours.skill_kit import keys

DESIGN = ROOT / "trees" / "design" / "six_bays.json"
TICK = 0.02  # s of wall time per tick
BUILD_TICKS = 10


class World:
    """What the simulated world needs here: where other cells' elements stand."""

    def __init__(self):
        self.standing: dict[str, list[float]] = {}

    def stand(self, element_id: str, pose) -> None:
        self.standing[element_id] = list(pose)


class Cell:
    def __init__(self):
        self.world = World()


class ScriptedBuild(py_trees.behaviour.Behaviour):
    def __init__(self, die_at: str | None, ticks: int = BUILD_TICKS):
        super().__init__("build")
        self.die_at = die_at
        self.ticks = ticks
        self.bb = self.attach_blackboard_client("build")
        self.bb.register_key(key=keys.ELEMENT, access=Access.READ)
        self.bb.register_key(key=keys.ASBUILT, access=Access.WRITE)

    def initialise(self) -> None:
        self.step = 0

    def update(self) -> Status:
        element = self.bb.get(keys.ELEMENT)
        if element["id"] == self.die_at:
            os._exit(9)  # a crash: the claim is never renewed again
        self.step += 1
        if self.step < self.ticks:
            return Status.RUNNING
        pose = (np.array(element["pick_pose"]) + [0, 0, 1.0, 0, 0, 0]).tolist()
        status = "placing" if self.step == self.ticks else "placed"
        self.bb.set(keys.ASBUILT, {"element": element["id"], "status": status, "pose": pose, "load": 20.0},
                    overwrite=True)
        return Status.RUNNING if status == "placing" else Status.SUCCESS


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("url")
    p.add_argument("cell")
    p.add_argument("run_dir", type=Path)
    p.add_argument("--die-at")
    p.add_argument("--credentials")
    p.add_argument("--build-ticks", type=int, default=BUILD_TICKS)
    p.add_argument("--lost-after", type=float, default=10.0, help="s of lost link before the cell stops")
    args = p.parse_args()
    args.run_dir.mkdir(parents=True, exist_ok=True)
    bridge = DesignBridge(DesignModel.load(DESIGN), args.run_dir / "asbuilt.json", args.run_dir / "events.jsonl")
    try:
        attach(bridge, args.url, args.cell, coordinated=True, security=LinkSecurity.load(args.credentials, lost_after=args.lost_after))
    except LinkError as exc:
        print(exc, file=sys.stderr)
        return 2
    node = ForEachElement("elements", ScriptedBuild(args.die_at, args.build_ticks))
    cell = Cell()
    node.setup(design=bridge.model, bridge=bridge, cell=cell)
    bridge.event("start", cell=args.cell)
    deadline = time.monotonic() + 120
    while node.status in (Status.INVALID, Status.RUNNING) and time.monotonic() < deadline:
        node.tick_once()
        fault = bridge.fault()
        if fault is not None:  # as the run's stop policy does: halt the tree, report, stop
            node.stop(Status.INVALID)
            bridge.event("fault", message=fault, element=node.current)
            bridge.close()
            return 3
        time.sleep(TICK)
    bridge.event("end", status=node.status.name, stood=sorted(cell.world.standing),
                 forged=getattr(bridge.dispatcher, "forged", 0))
    bridge.close()
    return 0 if node.status == Status.SUCCESS else 1


if __name__ == "__main__":
    raise SystemExit(main())
