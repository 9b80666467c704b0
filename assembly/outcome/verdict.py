"""The verdict of a simulated run from the scene's truth: a tree that ends in SUCCESS while the
truth shows the task was not done (an element propping its plate with too much regret, an object
dropped, the tool far from where it should be) ends TASK_FAILED instead, so a green simulated run
means the task was done. Each scene declares the tolerances it judges by; a tree may set them."""

from __future__ import annotations

from dataclasses import dataclass

from assembly.errors import TreeError
from assembly.language.reader import TreeDocument
from drivers.protocols import World
from fvfiles.errors import did_you_mean

TASK_FAILED = "TASK_FAILED"  # the tree said SUCCESS, the scene's truth says otherwise


@dataclass(frozen=True)
class Verdict:
    """What the scene's truth says of a simulated run: the tolerances it judged by and each way the
    task was not done (none: it was)."""

    tolerances: dict[str, float]
    shortfalls: list[str]


def tolerances_for(doc: TreeDocument, world: World) -> dict[str, float]:
    """The scene's tolerances with the tree's `cell.tolerances` over them; a name the scene does
    not judge by is a located error."""
    known = world.TOLERANCES
    for name in doc.tolerances:
        if name not in known:
            hint = did_you_mean(name, known) or (f"scene {doc.scene!r} has: {', '.join(sorted(known))}" if known
                                                 else f"scene {doc.scene!r} judges no tolerance")
            raise TreeError(f"cell.tolerances.{name}: scene {doc.scene!r} has no tolerance {name!r}",
                            doc.path, doc.tolerances.line_of(name), hint=hint)
    return {**known, **{name: float(value) for name, value in doc.tolerances.items()}}


def judge(world: World, tolerances: dict[str, float]) -> Verdict:
    """The verdict of the world's truth on the task, within `tolerances`."""
    return Verdict(tolerances, world.shortfalls(tolerances))
