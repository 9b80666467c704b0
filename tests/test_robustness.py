"""A shortened `fvtree bench robustness`: every demo tree over a few seeds of the randomised simulated
cell (sensor gains, rest jitter, skin lag up to 1 s, force-sensor offset up to 10 N, object, plate
and person drawn per seed), in signals mode, run in this process as the bench's batches run them.
No run may say SUCCESS with its task undone, and each demo must succeed on most seeds; a pixel-mode
run of the cheapest demo is marked slow. The full figures: `fvtree bench robustness` (README)."""

from __future__ import annotations

from pathlib import Path

import pytest

from assembly.bench.demos import TREES, demo_trees
from assembly.bench.robustness import KEYS, row_of, undone
from assembly.bench.robustness import randomised_cell as randomised_cell_file
from assembly.bench.run_batch import run_seeds
from assembly.cli import main

SEEDS = [0, 1, 2]
FLOOR = 2  # of the SEEDS runs of each demo that must succeed
HEAVY = {"assembly_heavy.yaml"}  # the longest demo: in the slow suite only
# Demos that fall short on the randomised cell for a reason a small skill change does not remove
# (README, `fvtree bench robustness`): strict, so a fix shows as an unexpected pass.
# (classify_substance was one until StirLearn's shape features, its deeper dip and one retry: 14 -> 18 of 20 seeds.)
SHORT: dict[str, str] = {}


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


def marks(tree: Path) -> list:
    out = [pytest.mark.slow] if tree.name in HEAVY else []
    return out + ([pytest.mark.xfail(reason=SHORT[tree.name], strict=True)] if tree.name in SHORT else [])


@pytest.mark.parametrize("tree", [pytest.param(t, id=t.stem, marks=marks(t)) for t in demo_trees(False)])
def test_each_demo_succeeds_honestly_on_randomised_seeds(tree, cell, tmp_path):
    check(runs(tree, "signals", cell, tmp_path, SEEDS), FLOOR)


@pytest.mark.slow
def test_a_pixel_mode_demo_succeeds_honestly_on_randomised_seeds(cell, tmp_path):
    tree = next(t for t in demo_trees(False) if t.name == "hold.yaml")
    check(runs(tree, "pixels", cell, tmp_path, SEEDS[:2]), 2)


def test_the_heaviest_randomised_plate_is_propped_at_its_maximum(cell, tmp_path):
    """assembly_heavy's P3 on seed 12 really pushes its prop with 95.5 N (~2 N of load noise), the
    heaviest of 20 seeds: one reading of 100.5 N stopped the rescan at `max_scan_force` 100 N. The scan's
    push is now measured from the force at rest and as a median over a few ticks. E3 alone (~25 s)."""
    from assembly.run.options import RunOptions
    from assembly.run.session import run_tree

    text = (TREES / "assembly_heavy.yaml").read_text()
    assert "for_each_element: elements" in text
    (tmp_path / "heavy.yaml").write_text(
        text.replace("design/", f"{TREES}/design/").replace("subtrees/", f"{TREES}/subtrees/")
        .replace("for_each_element: elements", "for_each_element: elements\n          elements: [E3]"))
    with pytest.MonkeyPatch.context() as patch:  # the copy includes the project's subtree and design
        patch.setenv("FVTREE_INCLUDE_PATH", str(TREES))
        result = run_tree(str(tmp_path / "heavy.yaml"), RunOptions(
            cell=str(cell), seed=12, perception="signals", runs_dir=tmp_path / "runs", plots=False, record=False,
            quiet=True))
    assert result.status == "SUCCESS", result.message
    e3 = result.elements["E3"]
    assert e3["true_max_load_N"] > 90.0 and abs(e3["position"] - e3["true_best_position"]) < 0.01, e3


def summary(status: str, **metrics) -> dict:
    return {"status": status, "metrics": metrics, "truth": {"tolerances": {"max_final_error_mm": 20.0}}}


def test_a_success_with_the_task_undone_is_flagged():
    follow = TREES / "force_track.yaml"
    assert undone(KEYS[follow.name], summary("SUCCESS", **{"tracking error rms (mm)": 12.0,
                                                            "tracking error final (mm)": 3.0}), follow) == ""
    assert "final" in undone(KEYS[follow.name], summary("SUCCESS", **{"tracking error final (mm)": 25.0}), follow)
    arm = TREES / "arm_rot.yaml"
    assert "from hanging" in undone(KEYS[arm.name], summary("SUCCESS", **{"stick from hanging (deg)": 89.9}), arm)
    press = TREES / "press_with_force.yaml"  # its target (5 N) is read from the tree
    assert undone(KEYS[press.name], summary("SUCCESS", **{"force on the scale (N)": 5.4}), press) == ""
    assert "force error" in undone(KEYS[press.name], summary("SUCCESS", **{"force on the scale (N)": 7.0}), press)
    build = TREES / "assembly.yaml"
    placed = {"status": "SUCCESS", "truth": {"tolerances": {"max_regret": 0.01}},
              "elements": {"E1": {"status": "placed", "regret": 0.02, "position": 0.5, "true_best_position": 0.45},
                           "E2": {"status": "planned"}}}
    assert "worst regret (%) 2 > 1" in undone(KEYS[build.name], placed, build)
    placed["elements"]["E1"]["regret"] = 0.001
    assert undone(KEYS[build.name], placed, build) == "1 of 2 elements placed"


def test_the_bench_writes_its_table_json_and_chart(tmp_path):
    assert main(["bench", "robustness", "--quick", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "robustness.md").read_text()
    assert "| hold.yaml | signals | 1/1 | 100% | 0 | box slid (mm) |" in text
    assert (tmp_path / "robustness.json").exists() and (tmp_path / "robustness.png").stat().st_size > 5_000
    assert not (tmp_path / "robustness_runs.jsonl").exists()


def test_the_sweep_options_belong_to_the_robustness_bench(tmp_path, capsys):
    assert main(["bench", "seeds", "--seeds", "3", "--out", str(tmp_path)]) == 2
    assert "do not apply to `fvtree bench seeds`" in capsys.readouterr().err
