"""The assembly's placements against the fingertip skin's lag: `python -m assembly.bench.skin_lag OUT`
runs trees/assembly.yaml on the simulated cell with the skin's fast time constant set to each lag
(no creep or hysteresis, so the lag alone is measured; and with the default profile's creep and
hysteresis; and at 1 s with the TCP force sensor's offset at 0, 5 and 10 N) and writes skin_lag_MODE[_one_way].md: per lag and element, the placement error (placed
minus the true maximum-load position, mm) and the force regret (%), with the run's verdict.
`--one-way` runs find_max_load as it was before it scanned both ways (`both_ways: false`), for the
before/after comparison."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from drivers.cell_file import CELLS_DIR

TREES = Path(__file__).resolve().parents[2] / "trees"
LAGS = (0.0, 0.3, 1.0, 3.0)
OFFSETS = (0.0, 5.0, 10.0)  # N, TCP force sensor offset


def assembly_tree(where: Path, one_way: bool) -> Path:
    """trees/assembly.yaml (copied to `where` with find_max_load scanning one way if `one_way`)."""
    if not one_way:
        return TREES / "assembly.yaml"
    shutil.copytree(TREES, where / "trees")
    subtree = where / "trees" / "subtrees" / "prop_plate.yaml"
    text = subtree.read_text()
    marked = text.replace("params: {span: [0.1, 0.9],", "params: {both_ways: false, span: [0.1, 0.9],")
    if marked == text:
        raise RuntimeError("find_max_load's call in trees/subtrees/prop_plate.yaml changed: update this bench")
    subtree.write_text(marked)
    return where / "trees" / "assembly.yaml"


def run_with_skin(lag: float, creep: bool, mode: str, runs_dir: Path, one_way: bool = False, seed: int = 0,
                  offset: float = 5.0) -> dict:
    """One `fvtree run trees/assembly.yaml` on a copy of the sim cell whose skin lags `lag` s and whose
    TCP force sensor reads `offset` N off."""
    tree = assembly_tree(runs_dir, one_way)
    cell = runs_dir / "cell.yaml"
    sensor = f"  skin_lag_s: {lag}\n" + ("" if creep else "  skin_creep_share: 0.0\n  skin_hysteresis: 0.0\n")
    text = (CELLS_DIR / "sim.yaml").read_text().replace("\nsensor:", "\nsensor:\n" + sensor.rstrip("\n"), 1)
    cell.write_text(text.replace("  offset: 5.0", f"  offset: {offset}", 1))
    command = [sys.executable, "-m", "assembly.cli", "run", str(tree), "--cell", str(cell), "--perception", mode,
               "--seed", str(seed), "--runs-dir", str(runs_dir), "--no-plots", "--no-record"]
    done = subprocess.run(command, check=False, capture_output=True, text=True)
    summaries = sorted(runs_dir.glob("*/summary.json"))
    if not summaries:
        return {"status": "NO SUMMARY", "message": done.stderr.strip()[-300:], "elements": {}}
    return json.loads(summaries[-1].read_text())


def rows(mode: str = "signals", one_way: bool = False) -> list[dict]:
    """One row per (lag, creep, offset, element): verdict, placement error (mm) and regret (%); one
    more naming why for a run that did not succeed."""
    out = []
    cases = [(lag, False, 5.0) for lag in LAGS] + [(lag, True, 5.0) for lag in (0.3, 1.0)]
    cases += [(1.0, True, offset) for offset in OFFSETS if offset != 5.0]
    for lag, creep, offset in cases:
        with tempfile.TemporaryDirectory() as tmp:
            summary = run_with_skin(lag, creep, mode, Path(tmp), one_way, offset=offset)
        case = {"lag_s": lag, "creep": creep, "offset": offset, "status": summary.get("status")}
        for eid, e in sorted((summary.get("elements") or {}).items()):
            if e.get("regret") is not None:
                out.append({**case, "element": eid, "error_mm": 1000.0 * (e["position"] - e["true_best_position"]),
                            "regret_pct": 100.0 * e["regret"]})
        if summary.get("status") != "SUCCESS":
            out.append({**case, "element": "why", "error_mm": float("nan"), "regret_pct": float("nan"),
                        "message": str(summary.get("message") or "")[:160]})
    return out


def markdown(table: list[dict], mode: str, one_way: bool) -> str:
    scan = "one-way scan (before)" if one_way else "scanned both ways"
    lines = [f"# Assembly placements against skin lag ({mode} mode, seed 0, {scan})", "",
             "| lag (s) | creep + hysteresis | force offset (N) | element | verdict | placement error (mm) | regret (%) |",
             "|---|---|---|---|---|---|---|"]
    for r in table:
        lines.append(f"| {r['lag_s']:g} | {'yes' if r['creep'] else 'no'} | {r['offset']:g} | {r['element']} | {r['status']} | "
                     f"{r['error_mm']:+.1f} | {r['regret_pct']:.2f} |" + (f" {r['message']}" if r.get("message") else ""))
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    args = list(sys.argv[1:] if argv is None else argv)
    one_way = "--one-way" in args
    args = [a for a in args if a != "--one-way"]
    out = Path(args[0] if args else ".")
    mode = args[1] if len(args) > 1 else "signals"
    out.mkdir(parents=True, exist_ok=True)
    text = markdown(rows(mode, one_way), mode, one_way)
    (out / f"skin_lag_{mode}{'_one_way' * one_way}.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
