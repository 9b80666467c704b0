"""`fvtree validate` stays quick enough to run on every save: it imports none of the libraries only a
run needs (scikit-learn, scipy, numba, OpenCV, Rerun, ...), which cost seconds. Timings are the
benchmark's (`fvtree bench validate`); this checks what makes them."""

from __future__ import annotations

import pytest

from assembly.bench.validate import heavy_imports


@pytest.mark.parametrize("tree", ["trees/assembly.yaml", "trees/press_with_force.yaml", "trees/classify_substance.yaml"])
def test_validate_imports_no_library_only_a_run_needs(tree):
    """The design's graph (networkx) is all; a tree's model file is checked without scikit-learn."""
    assert heavy_imports(tree) in ([], ["networkx"])
