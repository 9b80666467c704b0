"""Testing trees and skills, for tree and skill authors: `TreeHarness` ticks a tree by hand on a
mocked (or simulated) cell with scripted perception (`harness`); `check_skill` runs the contract
every skill must pass, on this project's skills and on a plug-in's (`skill_checks`)."""

from assembly.testing.harness import Command, TreeHarness, mock_cell, table, touch
from assembly.testing.skill_checks import check_skill, parametrize_with_skill_checks, skill_checks

__all__ = ["Command", "TreeHarness", "check_skill", "mock_cell", "parametrize_with_skill_checks", "skill_checks",
           "table", "touch"]
