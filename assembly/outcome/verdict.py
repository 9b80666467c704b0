"""The verdict of a simulated run from the scene's truth: a tree that ends in SUCCESS while the
truth shows the task was not done (an element propping its plate with too much regret, an object
dropped, a box hung in no grip, a press that never reached its force) ends TASK_FAILED instead, so
a green simulated run means the task was done. Each scene declares the tolerances it judges by
(`TOLERANCES`, with defaults) and the targets only the tree can know (`TARGETS`: the force a press
must reach, the turn an in-hand rotation must make); a tree sets either in `cell.tolerances`. A
target the tree leaves unset is not judged, and the verdict says so (`unjudged`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from assembly.errors import TreeError
from assembly.language.reader import TreeDocument
from drivers.protocols import World
from fvfiles.errors import did_you_mean

TASK_FAILED = "TASK_FAILED"  # the tree said SUCCESS, the scene's truth says otherwise


@dataclass(frozen=True)
class Verdict:
    """What the scene's truth says of a simulated run: the tolerances it judged by, each way the
    task was not done (none: it was) and what it could not judge (and why)."""

    tolerances: dict[str, float]
    shortfalls: list[str]
    unjudged: list[str] = field(default_factory=list)


def targets_of(world: World) -> Mapping[str, str]:
    """The scene's targets (name -> what it is), which only a tree can set; none for a scene
    that declares no `TARGETS`."""
    return getattr(world, "TARGETS", None) or {}


def tolerances_for(doc: TreeDocument, world: World) -> dict[str, float]:
    """The scene's tolerances with the tree's `cell.tolerances` over them, and the targets the
    tree sets; a name the scene does not judge by is a located error."""
    known = {**world.TOLERANCES, **dict.fromkeys(targets_of(world), 0.0)}
    for name in doc.tolerances:
        if name not in known:
            hint = did_you_mean(name, known) or (f"scene {doc.scene!r} has: {', '.join(sorted(known))}" if known
                                                 else f"scene {doc.scene!r} judges no tolerance")
            raise TreeError(f"cell.tolerances.{name}: scene {doc.scene!r} has no tolerance {name!r}",
                            doc.path, doc.tolerances.line_of(name), hint=hint)
    return {**world.TOLERANCES, **{name: float(value) for name, value in doc.tolerances.items()}}


def unset_targets(world: World, tolerances: Mapping[str, float]) -> list[str]:
    """A plain note for each target of the scene the tree left unset: that part of the task was
    not judged."""
    return [f"{name} ({what}): not judged, the tree sets no target (cell.tolerances.{name})"
            for name, what in targets_of(world).items() if name not in tolerances]


def judge(world: World, tolerances: dict[str, float], unjudged: list[str] | None = None) -> Verdict:
    """The verdict of the world's truth on the task, within `tolerances`; `unjudged` adds what the
    caller knows could not be judged (a marked element with no pose to stand it at)."""
    return Verdict(tolerances, world.shortfalls(tolerances), unset_targets(world, tolerances) + list(unjudged or []))
