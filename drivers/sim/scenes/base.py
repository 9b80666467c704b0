"""The defaults every simulated scene shares: a scene implements the World protocol, and most
have no measures or ground truth beyond what they override."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar


class Scene:
    """Base of the simulated scenes: empty `metrics` and `truth`; subclasses add `step` and
    `contacts` (and override the others where they know more)."""

    TOLERANCES: ClassVar[Mapping[str, float]] = {}  # name -> default limit, for `shortfalls`
    TARGETS: ClassVar[Mapping[str, str]] = {}  # name -> what it is: limits with no default, set by a tree or not judged
    # What the scene has for skills to work on (names of `behaviours.skill_kit.base.WORLD_NEEDS`): a
    # skill whose NEEDS it lacks is refused by validate; None: not declared, not checked (plug-ins).
    PROVIDES: ClassVar[frozenset[str] | None] = None

    def shortfalls(self, tolerances: Mapping[str, float]) -> list[str]:
        """What the scene's truth shows was not done (an object dropped, ...) within `tolerances`
        (the scene's TOLERANCES and the TARGETS the tree set); nothing by default."""
        return []

    def metrics(self) -> dict[str, Any]:
        """Scene measures of how the task went; none by default."""
        return {}

    def truth(self) -> dict[str, dict]:
        """Ground truth per task object for the run report; none by default."""
        return {}

    def labels(self) -> dict[str, Any]:
        """This tick's training labels for `fvtree record` (e.g. a scale reading); none by default."""
        return {}

    def label_info(self) -> dict[str, dict]:
        """What each label is (e.g. the scale's noise), stored with a recording; none by default."""
        return {}

    def stand(self, element_id: str, pose) -> None:
        """Stand an element the as-built model records as placed (a resumed run); scenes without
        elements have nothing to stand."""
