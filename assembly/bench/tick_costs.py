"""What each of the run's newer checks and models costs a tick, in microseconds, measured side by
side with it off.

Each repetition runs the assembly (trees/assembly.yaml, as `fvtree run` runs it: supervised and
recorded) once with everything on, timing each check's and model's own calls in this process (the
method is wrapped for the run, then put back; `CALLS`), and once more per check that a cell-file
setting or a run option turns off (the Groot2 monitor: `--groot2`; the arm, skin, force-sensor
models and the markers' rest jitter: `assembly.bench.sim_options`), alternating, so that each pair
sees the same machine load. The safety checks (SafeArm's look-ahead, the supervisor's margins, the
pipeline's frozen-region and colour checks) have no switch: a bench must not be a way to run a cell
without them; their cost is the time of their own calls. Pixel mode runs its fingers in this process
(`pixel_workers: false`) so that the pipeline's checks are timed too.

The skills' colour check (`behaviours.skill_kit.hand.false_object`: in_hand_rot and object_track,
not the assembly) is timed on the fingertip states of the last pixel-mode run, as it reads them
(with and without an object-colour warning to parse). find_max_load's two-way scan costs no time a
tick, but a second pass: the ticks of a run with `both_ways: false` are counted beside.
"""

from __future__ import annotations

import dataclasses
import importlib
import shutil
import statistics
import time
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from assembly.bench import write_csv
from assembly.bench.sim_options import option, option_cell
from assembly.bench.tick_timing import TREE, AssemblyRun, assembly_run, timed
from assembly.interop.groot2 import free_port_pair


@dataclass(frozen=True)
class Cost:
    """One check or model: the methods (`module:Class.method`) whose calls are its cost, the
    perception mode it is measured in, and what turns it off for the side-by-side run (an option of
    the sim cell, `groot2` for the monitor, None: no switch)."""

    name: str
    mode: str
    calls: tuple[str, ...]
    off: str | None = None  # a `sim_options` option's name, or "groot2" (on: served to Groot2)


COSTS: tuple[Cost, ...] = (
    Cost("Groot2 publish (monitor hook)", "signals", ("assembly.interop.groot2.server:Groot2Monitor.__call__",),
         "groot2"),
    Cost("arm model (latency, acceleration)", "signals", ("drivers.sim.devices.arm:KinematicArm.step",), "arm ideal"),
    Cost("skin model (lag, creep, hysteresis)", "signals", ("drivers.sim.models.skin:Skin.feel",), "skin off"),
    Cost("TCP force-sensor model", "signals", ("drivers.sim.models.force_sensor:SensorErrors.at",),
         "force sensor ideal"),
    Cost("SafeArm look-ahead (box one period ahead)", "signals", ("drivers.safety:SafeArm._crossing",)),
    Cost("supervisor Margins", "signals", ("assembly.run.supervisor:Margins.tick",
                                           "assembly.run.supervisor:Margins.saw")),
    Cost("pixel jitter redraw (marker drawing)", "pixels",
         ("drivers.sim.models.synthetic_camera:SyntheticFingerVision._clean_frame",), "rest jitter off"),
    Cost("colour check (pipeline: background match)", "pixels", ("perception.fingervision:FingerVision._object_warning",)),
    Cost("frozen-region check (per-region staleness)", "pixels", ("perception.frames:ImageQuality._frozen_region",)),
)


@contextmanager
def timed_calls(targets: tuple[str, ...]) -> Iterator[dict[str, list[float]]]:
    """While open, every call of each `module:Class.method` in `targets` appends its seconds to
    the list of that name; the methods are put back on leaving. A method that is not there (renamed)
    is an error naming it: the table must not show a cost of 0 for a check it did not see."""
    sinks: dict[str, list[float]] = defaultdict(list)
    undo: list[tuple[type, str, object]] = []
    try:
        for target in targets:
            module, _, qualified = target.partition(":")
            owner_name, _, method = qualified.rpartition(".")
            owner: Any = importlib.import_module(module)
            for part in owner_name.split("."):
                owner = getattr(owner, part)
            original = vars(owner).get(method)
            if original is None:
                raise RuntimeError(f"tick costs: {target} is gone; update assembly/bench/tick_costs.py")
            undo.append((owner, method, original))
            setattr(owner, method, timed(original, sinks[target]))
        yield sinks
    finally:
        for owner, method, original in reversed(undo):
            setattr(owner, method, original)


def _cells(out_dir: Path) -> dict[tuple[str, str | None], str]:
    """(mode, off switch) -> the cell file of that run: the sim cell as it is, each option's change;
    pixel mode with the fingers in this process."""
    import yaml

    cells: dict[tuple[str, str | None], str] = {}
    for mode in ("signals", "pixels"):
        for off in [None, *{c.off for c in COSTS if c.mode == mode and c.off not in (None, "groot2")}]:
            chosen = option(off or "all models on")
            path = option_cell(out_dir, chosen)
            if mode == "pixels":
                data = yaml.safe_load(path.read_text())
                data["pixel_workers"] = False
                if str(path) not in cells.values():  # a signals run's cell stays; only an intermediate goes
                    path.unlink()
                path = path.with_name(path.stem + "_one_process.yaml")
                path.write_text(yaml.safe_dump(data))
            cells[(mode, off)] = str(path)
    return cells


@dataclass
class Measured:
    """Per check or model and repetition: (median µs per call, calls per tick, mean µs per tick)
    of its own calls with it on; per (mode, switch, on?) the median whole tick of each run (s); the skills' colour check (s
    per call); a two-way and a one-way find_max_load run (ticks, CPU s, regrets)."""

    own: dict[str, list[tuple[float, float, float]]]
    whole: dict[tuple[str, str | None, bool], list[float]]
    false_object_s: dict[str, float]
    scan: dict[str, AssemblyRun]


def measure(out_dir: Path, repeats: int = 3, signals_time: float = 3600.0, pixels_time: float = 20.0) -> Measured:
    """`repeats` alternating repetitions; signals-mode runs last `signals_time` s of cell time at
    most (default: the whole assembly), pixel-mode runs `pixels_time`."""
    cells = _cells(out_dir)
    limits = {"signals": signals_time, "pixels": pixels_time}
    own: dict[str, list[tuple[float, float, float]]] = defaultdict(list)
    whole: dict[tuple[str, str | None, bool], list[float]] = defaultdict(list)
    last_pixels: AssemblyRun | None = None

    def run(mode: str, off: str | None, costs: list[Cost], groot2: bool = False) -> float:
        """One timed run; the own calls of `costs` recorded; its median whole tick."""
        with timed_calls(tuple(t for c in costs for t in c.calls)) as sinks:
            done = assembly_run(True, 0, cells[(mode, off)], perception=mode, max_time=limits[mode],
                                groot2=("127.0.0.1", free_port_pair()) if groot2 else None)
        ticks = max(done.result.ticks, 1)
        for cost in costs:
            times = [x for t in cost.calls for x in sinks.get(t, [])]
            own[cost.name].append((1e6 * statistics.median(times) if times else 0.0, len(times) / ticks,
                                   1e6 * sum(times) / ticks))
        if mode == "pixels":
            nonlocal last_pixels
            last_pixels = done
        assert done.times is not None
        return statistics.median(done.times.parts["whole tick"])

    for _ in range(repeats):
        for mode in ("signals", "pixels"):
            base = run(mode, None, [c for c in COSTS if c.mode == mode and c.off != "groot2"])
            for cost in (c for c in COSTS if c.mode == mode and c.off is not None):
                if cost.off == "groot2":  # off by default: the base run is the one without
                    whole[(mode, cost.off, False)].append(base)
                    whole[(mode, cost.off, True)].append(run(mode, None, [cost], groot2=True))
                else:
                    whole[(mode, cost.off, True)].append(base)
                    whole[(mode, cost.off, False)].append(run(mode, cost.off, []))
    for path in set(cells.values()):
        Path(path).unlink(missing_ok=True)
    return Measured(dict(own), dict(whole), _false_object_times(last_pixels), _scan_runs(out_dir, signals_time))


def _false_object_times(done: AssemblyRun | None, calls: int = 2000) -> dict[str, float]:
    """Seconds per call of the skills' colour check on the last fingertip states of a pixel run,
    as they are and with an object-colour warning in their health reason (the case that parses)."""
    from behaviours.skill_kit.hand import false_object
    from perception.state import OBJECT_UNRELIABLE

    if done is None or not done.states:
        return {}
    left, right = done.states["left"], done.states["right"]
    warned = tuple(dataclasses.replace(s, health_reason=f"{OBJECT_UNRELIABLE} 1.5% of the empty view (glare)")
                   for s in (left, right))
    areas = {"left": 0.2, "right": 0.2}
    out = {}
    for name, states in (("as read", (left, right)), ("with a colour warning", warned)):
        start = time.perf_counter()
        for _ in range(calls):
            false_object(states, areas, 0.1)
        out[name] = (time.perf_counter() - start) / calls
    return out


def _scan_runs(out_dir: Path, max_time: float) -> dict[str, AssemblyRun]:
    """A signals-mode assembly with find_max_load scanning both ways (its default) and one way
    (`both_ways: false`, through a copy of the tree whose prop_plate subtree says so)."""
    trees = TREE.parent
    copy = out_dir / "one_way_tree"
    (copy / "subtrees").mkdir(parents=True, exist_ok=True)
    (copy / "assembly.yaml").write_text(TREE.read_text())
    shutil.copytree(trees / "design", copy / "design", dirs_exist_ok=True)  # a tree reads only its own folder
    text = (trees / "subtrees" / "prop_plate.yaml").read_text()
    one_way = text.replace("{skill: find_max_load, name: find_load, params: {",
                           "{skill: find_max_load, name: find_load, params: {both_ways: false, ")
    if one_way == text:
        raise RuntimeError("trees/subtrees/prop_plate.yaml has no find_max_load node: update tick_costs.py")
    (copy / "subtrees" / "prop_plate.yaml").write_text(one_way)
    try:
        return {"both ways": assembly_run(False, 0, max_time=max_time),
                "one way": assembly_run(False, 0, max_time=max_time, tree=copy / "assembly.yaml")}
    finally:
        shutil.rmtree(copy)


def rows(m: Measured) -> list[dict]:
    """One row per check or model: calls per tick and µs per tick of its own calls (all on), the
    median whole tick with it on and off, and their difference (µs; empty: no switch)."""
    out = []
    for cost in COSTS:
        per_call = statistics.median(us for us, _, _ in m.own[cost.name])
        calls = statistics.median(n for _, n, _ in m.own[cost.name])
        row = {"check or model": cost.name, "mode": cost.mode, "timed": ", ".join(c.partition(":")[2] for c in cost.calls),
               "calls per tick": calls, "µs per call": per_call, "own calls µs per tick": per_call * calls,
               "mean µs per tick": statistics.median(us for _, _, us in m.own[cost.name]),
               "whole tick µs, on": None, "whole tick µs, off": None, "difference µs": None,
               "off for the comparison": _how_off(cost)}
        if cost.off is not None:
            on, off = (statistics.median(m.whole[(cost.mode, cost.off, flag)]) * 1e6 for flag in (True, False))
            row.update({"whole tick µs, on": on, "whole tick µs, off": off, "difference µs": on - off})
        out.append(row)
    for name, seconds in m.false_object_s.items():
        out.append({"check or model": f"colour check (skills: false_object, {name})", "mode": "pixels",
                    "timed": "behaviours.skill_kit.hand.false_object", "calls per tick": 1.0,
                    "mean µs per tick": seconds * 1e6, "own calls µs per tick": seconds * 1e6, "µs per call": seconds * 1e6,
                    "whole tick µs, on": None, "whole tick µs, off": None, "difference µs": None,
                    "off for the comparison": "not in the assembly: timed on its last fingertip states"})
    if m.scan:
        both, one = m.scan["both ways"], m.scan["one way"]
        out.append({"check or model": "find_max_load two-way scan", "mode": "signals", "timed": "whole run",
                    "calls per tick": None, "own calls µs per tick": None, "µs per call": None, "mean µs per tick": None,
                    "whole tick µs, on": 1e6 * both.cpu_per_tick, "whole tick µs, off": 1e6 * one.cpu_per_tick,
                    "difference µs": 1e6 * (both.cpu_per_tick - one.cpu_per_tick),
                    "off for the comparison": (f"`both_ways: false` (CPU µs per tick; the run: {both.result.ticks} "
                                               f"ticks, {both.cpu:.1f} s CPU, regrets {_regrets(both)} % both ways; "
                                               f"{one.result.ticks} ticks, {one.cpu:.1f} s CPU, regrets "
                                               f"{_regrets(one)} % one way)")})
    return out


def _regrets(done: AssemblyRun) -> str:
    from assembly.bench.robustness import regrets

    values = regrets(done.summary.to_json())
    return ", ".join(f"{v:.3f}" for v in values) or "none placed"


def _how_off(cost: Cost) -> str:
    if cost.off is None:
        return "no switch (a safety check): its own calls timed"
    if cost.off == "groot2":
        return "run without --groot2 (on: served to Groot2 on 127.0.0.1, no client)"
    return f"sim cell option `{cost.off}` ({option(cost.off).about})"


COLUMNS = ["check or model", "mode", "timed", "calls per tick", "µs per call", "own calls µs per tick",
           "mean µs per tick", "whole tick µs, on", "whole tick µs, off", "difference µs", "off for the comparison"]


def write_table(table: list[dict], path: Path) -> Path:
    def cell(value):
        return "" if value is None else f"{value:.4g}" if isinstance(value, float) else value
    return write_csv(path, [{k: cell(r[k]) for k in COLUMNS} for r in table], COLUMNS)


def markdown(table: list[dict], repeats: int, pixels_time: float) -> list[str]:
    def num(value):
        return "—" if value is None else f"{value:.3g}"
    lines = ["## Per-tick cost of the checks and models", "",
             (f"Median of {repeats} repetitions, each an all-on run beside one run per switch turned off, alternating "
              f"(signals mode: the whole assembly; pixel mode: its first {pixels_time:g} s, fingers in this process). "
              "Timed: the methods whose calls are the check's or model's cost (the arm's whole step, the skin's whole "
              "`feel`). µs per call: their median call; own calls µs per tick: that times the calls per tick (robust "
              "to a loaded machine's pauses); mean µs per tick: their total time over the ticks. Whole tick: the "
              "median tick (handlers, tree and cell step) of the run with it on and of the run with it off; "
              "their difference is everything the switch changes downstream (markers without rest jitter also "
              "spare the pipeline work on a still skin) and within the machine's noise for checks of a few µs. "
              "The mean takes in the pauses a loaded machine puts into a call; the median does not. The two-way "
              "scan's row compares CPU µs per tick of whole runs."), "",
             ("| check or model | mode | timed | calls per tick | µs per call | own calls µs per tick | mean µs per "
              "tick | whole tick µs, on | whole tick µs, off | difference µs | off for the comparison |"),
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in table:
        lines.append(f"| {r['check or model']} | {r['mode']} | {r['timed']} | {num(r['calls per tick'])} | "
                     f"{num(r['µs per call'])} | {num(r['own calls µs per tick'])} | {num(r['mean µs per tick'])} | "
                     f"{num(r['whole tick µs, on'])} | {num(r['whole tick µs, off'])} | {num(r['difference µs'])} | "
                     f"{r['off for the comparison']} |")
    return [*lines, ""]
