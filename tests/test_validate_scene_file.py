"""The scene file next to a tree's design (`<design>.scene.yaml`, the plates' loads in simulation) is
checked when the tree is validated, not first when the simulated scene is built."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from assembly.errors import TreeErrors
from assembly.language.reader import load_tree

DESIGN = Path(__file__).resolve().parents[1] / "trees" / "design"
TREE = "version: 1\nname: t\ndesign: design/two_bays.json\nroot: {skill: estop_guard, name: e}\n"


def tree_with_scene_file(tmp_path: Path, change: tuple[str, str]) -> Path:
    (tmp_path / "design").mkdir()
    shutil.copy(DESIGN / "two_bays.json", tmp_path / "design")
    scene = (DESIGN / "two_bays.scene.yaml").read_text()
    assert change[0] in scene
    (tmp_path / "design" / "two_bays.scene.yaml").write_text(scene.replace(*change))
    (tmp_path / "t.yaml").write_text(TREE)
    return tmp_path / "t.yaml"


@pytest.mark.parametrize("change, line, field, message", [
    (("c: 0.78", "c: 1.6"), 5, "plates.P1.c", "scene file: the point load must lie on the span [0, 1] m, got 1.6"),
    (("  P2:", "  p2:"), 6, "plates.p2", "scene file: the design has no plate 'p2'"),
    (("EI: 50.0", "EI: -5.0"), 5, "plates.P1.EI", "scene file: must be positive, got -5.0"),
])
def test_a_scene_file_that_does_not_fit_the_design_is_refused_with_its_line(tmp_path, change, line, field, message):
    with pytest.raises(TreeErrors) as caught:
        load_tree(tree_with_scene_file(tmp_path, change))
    (error,) = caught.value.errors
    assert (Path(error.file).name, error.line, error.path, error.message) == ("two_bays.scene.yaml", line, field,
                                                                              message)


def test_a_scene_file_that_fits_passes(tmp_path):
    assert load_tree(tree_with_scene_file(tmp_path, ("c: 0.78", "c: 0.5"))).design is not None
