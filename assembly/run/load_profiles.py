"""The load profiles a run measures, by element, for the summary and its chart."""

from __future__ import annotations

import py_trees
from py_trees.blackboard import Blackboard

from behaviours.skill_kit import keys


class LoadProfiles:
    """Post-tick handler keeping every new /task/load_profile under the id of the element being
    built (/task/element), or `#n` outside an element iteration."""

    def __init__(self):
        self.profiles: dict[str, dict] = {}
        self._last = None

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        profile = Blackboard.storage.get(keys.LOAD_PROFILE)
        if profile is not None and profile is not self._last:
            self._last = profile
            element = Blackboard.storage.get(keys.ELEMENT, {}).get("id", f"#{len(self.profiles)}")
            self.profiles[element] = profile
