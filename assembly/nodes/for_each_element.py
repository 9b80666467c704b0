"""Iteration over the design model's elements in build order, resuming past placed ones."""

from __future__ import annotations

import py_trees
from py_trees.common import Access, Status

from assembly.design.bridge import DesignBridge
from assembly.design.model import WAIT, DesignModel
from assembly.nodes.decorators import DirectDecorator
from behaviours.skill_kit import keys
from behaviours.skill_kit.base import KeyReads
from behaviours.skill_kit.retreat import FinishRetreat
from drivers.protocols import World


class ForEachElement(DirectDecorator, py_trees.decorators.Decorator):
    """Runs its child once per unplaced element, in build order.

    Between two elements the design bridge applies the design changes its live links received
    (new or changed planned elements join the order; placements by other cells are stood in the
    simulated world) and names the next element (with several cells, a coordinator may say to
    wait: the child is not ticked meanwhile). Before each run it publishes the element's design
    entry on /task/element (and the plates on /task/plates). After each tick of the child it
    hands a new /task/asbuilt record of the element to the design bridge, which writes it
    durably before the next tick: `placing` (the skill is about to open the fingers) and then
    `placed`, then `retreated` once the arm has backed out. SUCCESS when every element is placed;
    FAILURE as soon as one element fails, or its child succeeds without a `placed` record (the
    model keeps what was placed, so a re-run resumes there). A run resumed after a session that
    stopped between an element's `placed` and `retreated` records first finishes that way out
    (`FinishRetreat`), from where the arm stands: only then the next element, or the rest of the tree.
    """

    design: DesignModel  # from `setup(design=...)`, which refuses a tree without one

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, only: list[str] | None = None):
        super().__init__(name=name, child=child)
        self.only = only
        self.bridge: DesignBridge | None = None
        self.world: World | None = None  # the simulated world, which stands what other cells placed
        self.current: str | None = None
        self._node: dict | None = None  # the current element's attributes in the design graph (live)
        self.waiting = False  # the dispatcher said to wait for another cell
        self._record: dict | None = None  # the last /task/asbuilt record handed on
        self.retreat: FinishRetreat | None = None  # the way out a stopped session left unfinished
        self.bb = self.attach_blackboard_client(name=name)
        for key in (keys.ELEMENT, keys.PLATES):
            self.bb.register_key(key=key, access=Access.WRITE)
        self.bb.register_key(key=keys.ASBUILT, access=Access.READ)
        self.reads = KeyReads(self.bb)

    def setup(self, **kwargs) -> None:
        design = kwargs.get("design")
        self.bridge = kwargs.get("bridge")
        self.world = getattr(kwargs.get("cell"), "world", None)
        if design is None:
            raise RuntimeError(f"{self.name}: for_each_element needs a design model (tree 'design:')")
        self.design = design
        way_out = self.bridge.unfinished_retreat if self.bridge is not None else None
        if way_out is not None:
            self.retreat = FinishRetreat(f"{self.name}/finish_retreat", way_out["element"], way_out["path"],
                                         way_out["speed"])
            self.retreat.setup(**kwargs)

    def remaining(self) -> list[str]:
        order = self.design.build_order()
        if self.only is not None:
            order = [e for e in order if e in self.only]
        return [e for e in order if not self.design.is_placed(e)]

    def _left_placing(self) -> bool:
        """The current element's release began before this attempt and was never confirmed:
        building it again could place it twice, so a person must check it first."""
        return self._record is None and self._node is not None and self._node.get("status") == "placing"

    def _publish_next(self) -> None:
        """At an element boundary: take in design changes, then publish the next element."""
        if self.bridge is not None:
            for eid in self.bridge.at_boundary():
                node = self.design.graph.nodes[eid]
                if self.world is not None and node.get("status") == "placed" and node.get("cell"):
                    self.world.stand(eid, node["asbuilt_pose"])  # placed by another cell (or before a restart)
        remaining = self.remaining()
        choice = self.bridge.next_element(remaining) if self.bridge else (remaining[0] if remaining else None)
        self.waiting = choice == WAIT
        self.current = None if self.waiting else choice
        # Looked up once per element (design changes replace nodes only at boundaries, above); read live.
        self._node = None if self.current is None else self.design.graph.nodes[self.current]
        self._record = None
        if self.waiting:
            self.feedback_message = "waiting for another cell"
        elif self.current is not None:
            self.bb.set(keys.ELEMENT, self.design.element(self.current), overwrite=True)
            self.bb.set(keys.PLATES, self.design.plates(), overwrite=True)
            self.feedback_message = f"element {self.current}"
            if self.bridge is not None:
                self.bridge.notify({"event": "picking", "element": self.current})

    def initialise(self) -> None:
        self._publish_next()

    def tick(self):
        """py_trees' generator tick (for trees ticked with visitors); `tick_once` without it."""
        new_status = self._status_without_child()
        if new_status is None:
            yield from self.decorated.tick()
            new_status = self.update()
        self.end_tick(new_status)
        yield self

    def tick_once(self) -> None:
        """The runner's tick, without generators (`assembly.nodes.composites`): the steps of `tick`."""
        new_status = self._status_without_child()
        if new_status is None:
            self.decorated.tick_once()
            new_status = self.update()
        self.end_tick(new_status)

    def _status_without_child(self) -> Status | None:
        """The start of a tick: publish the next element when starting or waiting; this tick's
        status when the child is not to tick (waiting, a placement to check, nothing left, the way
        out of an element placed before a resume), else None."""
        if self.retreat is not None:
            status = self._finish_retreat()
            if status is not None:
                return status
            self.initialise()
        elif self.status != Status.RUNNING:
            self.initialise()
        elif self.waiting:
            self._publish_next()
        if self.waiting:
            return Status.RUNNING
        if self._left_placing():
            self.feedback_message = (f"element {self.current} was being released when its placement "
                                     "stopped: check it before building it again")
            return Status.FAILURE
        if self.current is None:  # nothing left to build
            self.feedback_message = "all elements placed"
            return Status.SUCCESS
        return None

    def _finish_retreat(self) -> Status | None:
        """One tick of the way out left unfinished: RUNNING or FAILURE, or None once backed out."""
        retreat = self.retreat
        assert retreat is not None
        retreat.tick_once()
        self.feedback_message = retreat.feedback_message
        if retreat.status == Status.RUNNING:
            return Status.RUNNING
        if retreat.status == Status.FAILURE:
            if self.bridge is not None:
                self.bridge.event("failed", element=retreat.element, node=retreat.name,
                                  feedback=retreat.feedback_message)
            return Status.FAILURE
        if self.bridge is not None:
            self.bridge.record_retreat(retreat.element)
        self.retreat = None
        return None

    def terminate(self, new_status: Status) -> None:
        if self.retreat is not None and self.retreat.status == Status.RUNNING:
            self.retreat.stop(new_status)  # halted while backing out: the arm stops
        super().terminate(new_status)

    def update(self) -> Status:
        status = self.decorated.status
        self._hand_on_record()
        if status == Status.FAILURE:
            if self.bridge:
                tip = self.decorated.tip()
                self.bridge.event("failed", element=self.current, node=self.decorated.name,
                                  feedback=tip.feedback_message if tip else "")
            return Status.FAILURE
        if status != Status.SUCCESS:
            return status
        if self._record is None or self._record.get("status", "placed") not in ("placed", "retreated"):
            self.feedback_message = f"{self.current}: child succeeded without recording an as-built pose"
            return Status.FAILURE
        self._publish_next()
        return Status.SUCCESS if self.current is None and not self.waiting else Status.RUNNING

    def _hand_on_record(self) -> None:
        """Record a new /task/asbuilt record of the current element (`placing`, `placed` or `retreated`)."""
        record = self.reads.get(keys.ASBUILT)
        if record is None or record is self._record or record.get("element") != self.current:
            return
        self._record = record
        status = record.get("status", "placed")
        element, node = self.current, self._node
        assert element is not None and node is not None  # the child ticks only with an element to build
        if status == "retreated":
            if self.bridge is not None:
                self.bridge.record_retreat(element)
        elif self.bridge is None:
            node["status"] = status
        elif status == "placing":
            self.bridge.record_placing(element, record["pose"], record.get("load"))
        else:
            self.bridge.record_placement(element, record["pose"], record.get("load"), record.get("retreat"))
