"""Dataflow before the first tick: a node reading a blackboard key that nothing ticking before it
writes (and the cell's perception stage does not publish) is a validation error naming it."""

from __future__ import annotations

from pathlib import Path

import pytest

from assembly.errors import TreeErrors
from assembly.language.reader import load_tree

TREES = Path(__file__).resolve().parents[1] / "trees"
DESIGN = TREES / "design" / "two_bays.json"


def problems(root: str, design: bool = False) -> list[str]:
    text = f"version: 1\nname: t\n{f'design: {DESIGN}' if design else ''}\nroot:\n{root}"
    try:
        load_tree(text=text, name="t.yaml")
    except TreeErrors as exc:
        return [str(e) for e in exc.errors]
    return []


def test_a_skill_alone_that_needs_the_task_is_refused_naming_skill_and_key():
    [element, plates] = problems("  skill: approach_plate\n")  # /task/element_length is optional
    assert "t.yaml:5: approach_plate: skill 'approach_plate' reads /task/element" in element
    assert "written by for_each_element" in element and "/task/plates" in plates


def test_keys_read_with_a_fallback_need_no_writer():
    """Without vis_scan the element's measured length is unknown: the skills that read it fall
    back on the design length (or skip a check), so the tree is valid."""
    tree = ("  for_each_element: each\n  child:\n    sequence: s\n    memory: true\n    children:\n"
            "      - {skill: locate_element}\n      - {skill: gentle_grasp}\n      - {skill: rotate_element}\n"
            "      - {skill: approach_plate}\n      - {skill: find_max_load}\n      - {skill: place_element}\n")
    assert problems(tree, design=True) == []


def test_place_element_outside_for_each_element_is_refused():
    found = problems("  sequence: s\n  memory: true\n  children:\n    - {skill: find_max_load}\n"
                     "    - {skill: vis_scan}\n    - {skill: place_element}\n")
    assert any("s/find_max_load: skill 'find_max_load' reads /task/element," in p for p in found)
    assert any("s/place_element: skill 'place_element' reads /task/element," in p for p in found)
    assert not any("place_element' reads /task/measured_load" in p for p in found)  # find_max_load ran before


def test_the_order_of_siblings_matters_in_a_sequence_and_not_in_a_parallel():
    body = "    - {{skill: {0}}}\n    - {{skill: {1}}}\n"
    inside = "  for_each_element: each\n  child:\n    {kind}: s\n    {extra}\n    children:\n" + body
    sequence = inside.replace("{kind}", "sequence").replace("{extra}", "memory: true")
    parallel = inside.replace("{kind}", "parallel").replace("{extra}", "policy: all")
    assert problems(sequence.format("find_max_load", "place_element"), design=True) == []
    [late] = problems(sequence.format("place_element", "find_max_load"), design=True)
    assert "each/s/place_element: skill 'place_element' reads /task/measured_load" in late
    assert problems(parallel.format("place_element", "find_max_load"), design=True) == []


def test_skills_that_keep_their_own_state_and_perception_readers_are_fine():
    assert problems("  skill: stir\n") == []  # reads the /task/stir_trial it writes
    assert problems("  skill: gentle_grasp\n") == []  # perception only


@pytest.mark.parametrize("tree", sorted(TREES.glob("*.yaml")), ids=lambda p: p.name)
def test_no_false_errors_on_the_shipped_trees(tree):
    load_tree(tree)  # raises on any problem, dataflow included


def test_tests_that_set_keys_by_hand_can_skip_the_check():
    assert load_tree(text="version: 1\nname: t\nroot: {skill: approach_plate}\n", dataflow=False)


def test_a_condition_or_guard_on_a_key_written_only_later_is_refused():
    later = ("  sequence: s\n  memory: true\n  children:\n"
             "    - {condition: grasped, key: /task/grasp_width, op: gt, value: 0.01}\n"
             "    - {skill: gentle_grasp, name: grasp}\n")
    [problem] = problems(later)
    assert "t.yaml:8: s/grasped: condition 'grasped' reads /task/grasp_width" in problem
    assert "written by skill gentle_grasp" in problem
    guarded = ("  guard: while_held\n  while: {key: /task/grasp_width, op: gt, value: 0.01}\n"
               "  child: {skill: gentle_grasp, name: grasp}\n")
    [problem] = problems(guarded)
    assert "guard 'while_held' reads /task/grasp_width" in problem
    before = ("  sequence: s\n  memory: true\n  children:\n    - {skill: gentle_grasp, name: grasp}\n"
              "    - {condition: grasped, key: /task/grasp_width, op: gt, value: 0.01}\n")
    assert problems(before) == []


def test_a_condition_asking_whether_a_key_exists_needs_no_writer_before_it():
    """`exists` asks whether the key has been written (skip a step already done): it reads no value."""
    skip = ("  selector: once\n  memory: false\n  children:\n"
            "    - {condition: done, key: /task/grasp_width, op: exists}\n    - {skill: gentle_grasp, name: grasp}\n")
    assert problems(skip) == []
