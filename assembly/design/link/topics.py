"""The MQTT topics of the design link and the shape of their messages (JSON through compas_eve's
codec: COMPAS objects travel as {"dtype": ..., "data": ...} and come back as COMPAS objects).

One cell (`fvtree run ... --bridge mqtt://HOST:PORT --cell-name NAME`), under `fvtree/NAME/`:
  plan       out, retained: the live design as a COMPAS Graph (compas_data), after every change
  status     out: {"element", "status", "frame" (Frame or null), "load" (N or null), "cell", "time"}
  events     out: a run event {"event": start|halted|estop|fault|crashed|failed|retreated|design_updated|end, ...}
  updates    in:  {"update": ID, "elements": [element nodes], "edges": [{"source", "target"}]}
  conflicts  out: {"update", "element", "reason"}: a change refused (the element is built or being built)
  errors     out: {"update" (or null), "error", "topic"}: a message that could not be read or applied
Several cells on one design, under `fvtree/design/DESIGN/`:
  plan       out, retained: the coordinator's design (COMPAS Graph): who placed what
  claims     in:  {"op": claim|renew|placing|placed|failed, "cell", "request", "lease", "element", "pose", "load"}
  cells/CELL out: the coordinator's answer to CELL's request {"request", "op"} and one of
             {"element", "lease", "lease_s"} (granted), {"wait": true, "unplaced"}, {"done": true},
             {"element", "status"} (report taken) or {"refused": reason}
  log        out: what the coordinator decided, in order {"what": granted|placing|placed|failed|
             expired|stuck|refused, "cell", "element", "time", ...}
  errors     out: {"error", "topic"}: a request that could not be read
With signing secrets (assembly.design.link.signing) a request and an answer also carry "sig" (an
answer names its "cell"), and the plan carries "signatures" {CELL: sig} beside "dtype" and "data".
Who may publish where on a secured broker: examples/secure_broker/acl.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from assembly.errors import TreeError

ROOT = "fvtree"
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


def check_name(name: object, what: str) -> str:
    """A cell or design name fit for one topic level (no '/', '+', '#', spaces)."""
    if not isinstance(name, str) or not _NAME.match(name):
        raise TreeError(f"{what} {name!r} cannot name an MQTT topic level",
                        hint="use letters, digits, '_', '-' and '.', at most 64 characters")
    return name


@dataclass(frozen=True)
class CellTopics:
    """The topics of one cell's design link."""

    cell: str

    def __post_init__(self):
        check_name(self.cell, "cell name")

    def _topic(self, leaf: str) -> str:
        return f"{ROOT}/{self.cell}/{leaf}"

    plan = property(lambda self: self._topic("plan"))
    status = property(lambda self: self._topic("status"))
    events = property(lambda self: self._topic("events"))
    updates = property(lambda self: self._topic("updates"))
    conflicts = property(lambda self: self._topic("conflicts"))
    errors = property(lambda self: self._topic("errors"))


@dataclass(frozen=True)
class DesignTopics:
    """The topics of a coordinator and the cells building its design."""

    design: str

    def __post_init__(self):
        check_name(self.design, "design name")

    plan = property(lambda self: f"{ROOT}/design/{self.design}/plan")
    claims = property(lambda self: f"{ROOT}/design/{self.design}/claims")
    log = property(lambda self: f"{ROOT}/design/{self.design}/log")
    errors = property(lambda self: f"{ROOT}/design/{self.design}/errors")

    def replies(self, cell: str) -> str:
        return f"{ROOT}/design/{self.design}/cells/{check_name(cell, 'cell name')}"
