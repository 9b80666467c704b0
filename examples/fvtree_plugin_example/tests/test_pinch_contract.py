"""The skill contract on this package's `pinch` skill, one pytest case per check: the test a plug-in
author writes to learn, before fvtree's users do, that the skill validates its params, stops the
devices when halted, reads only keys something writes, reads robot state from the tick's snapshot,
ends within a bound and shows up in `fvtree skills` and the tree schema. Run it with the package
installed (`pip install -e .`, so that fvtree finds the skill through its entry point), then
`pytest`. `assembly.testing.check_skill(Pinch)` runs the same checks in one call."""

from fvtree_plugin_example.pinch import Pinch

from assembly.testing import parametrize_with_skill_checks


@parametrize_with_skill_checks([Pinch])
def test_pinch_keeps_the_skill_contract(check):
    check()
