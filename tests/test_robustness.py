"""A shortened `fvtree bench robustness`: every demo tree over a few seeds of the randomised simulated
cell (sensor gains, rest jitter, skin lag up to 1 s, force-sensor offset up to 10 N, object, plate
and person drawn per seed), in signals mode, run in this process as the bench's batches run them.
No run may say SUCCESS with its task undone, and each demo must succeed on most seeds; a pixel-mode
run of the cheapest demo is marked slow. The full figures: `fvtree bench robustness` (README)."""

from __future__ import annotations

from pathlib import Path

import pytest

from assembly.bench.demos import demo_trees
from assembly.bench.robustness import randomised_cell as randomised_cell_file
from assembly.bench.robustness import row_of
from assembly.bench.run_batch import run_seeds

SEEDS = [0, 1, 2]
FLOOR = 2  # of the SEEDS runs of each demo that must succeed
HEAVY = {"assembly_heavy.yaml"}  # the longest demo: in the slow suite only


@pytest.fixture(scope="module")
def cell(tmp_path_factory) -> Path:
    return randomised_cell_file(tmp_path_factory.mktemp("cell"))


def runs(tree: Path, mode: str, cell: Path, where: Path, seeds: list[int]) -> list[dict]:
    return [row_of(tree, mode, s["seed"], s) for s in run_seeds(str(tree), mode, str(cell), where, seeds)]


def check(rows: list[dict], floor: int) -> None:
    lies = [f"seed {r['seed']}: {r['dishonest']}" for r in rows if r.get("dishonest")]
    assert not lies, f"{rows[0]['tree']} said SUCCESS with its task undone: {lies}"
    ok = [r for r in rows if r["status"] == "SUCCESS"]
    failed = [f"seed {r['seed']} (lag {r['skin_lag_s']} s, offset {r['force_offset_N']} N): {r['status']} {r.get('why')}"
              for r in rows if r["status"] != "SUCCESS"]
    assert len(ok) >= floor, f"{rows[0]['tree']}: {len(ok)} of {len(rows)} randomised seeds succeeded: {failed}"


@pytest.mark.parametrize("tree", [pytest.param(t, id=t.stem, marks=[pytest.mark.slow] if t.name in HEAVY else [])
                                  for t in demo_trees(False)])
def test_each_demo_succeeds_honestly_on_randomised_seeds(tree, cell, tmp_path):
    check(runs(tree, "signals", cell, tmp_path, SEEDS), FLOOR)


@pytest.mark.slow
def test_a_pixel_mode_demo_succeeds_honestly_on_randomised_seeds(cell, tmp_path):
    tree = next(t for t in demo_trees(False) if t.name == "hold.yaml")
    check(runs(tree, "pixels", cell, tmp_path, SEEDS[:2]), 2)
