"""`fvtree bench drivers`: servo streaming rate and command latency through the UR driver and
ur_rtde to the loopback controller emulator (e-Series 500 Hz, and CB3 125 Hz unless --quick).

Writes drivers.csv, drivers.md and drivers.png to the output directory. Latencies are the time a
driver call takes to return: for servoL (a streaming command) until the packet is sent, for moveL
(asynchronous) and stopL until the controller acknowledged it over RTDE. The streaming rate is
counted on the emulator's clock. Loopback and a Python emulator: an upper bound on what the
client costs, not a measurement of a real controller.

    python -m assembly.bench.drivers --out DIR [--quick]
"""

from __future__ import annotations

import csv
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from assembly.bench import script
from drivers.clock import WallClock
from drivers.emulators import backdoor
from drivers.emulators.launch import EmulatorProcess
from drivers.hardware.ur import UrArm, UrConfig

_NET = f"127.6.{os.getpid() % 250}"  # per process: two benches at once must not share emulators
CONTROLLERS = {"e-Series (500 Hz)": (f"{_NET}.2", []), "CB3 (125 Hz)": (f"{_NET}.3", ["--cb3"])}


@dataclass
class Row:
    controller: str
    measure: str
    n: int
    median_ms: float
    p99_ms: float
    rate_hz: float | None = None  # achieved / nominal rate for streaming rows


def _stats(controller: str, measure: str, seconds: list[float], rate: float | None = None) -> Row:
    ms = np.asarray(seconds) * 1000.0
    return Row(controller, measure, len(ms), float(np.median(ms)), float(np.percentile(ms, 99)), rate)


def bench_controller(label: str, host: str, args: list[str], stream_s: float, repeats: int) -> list[Row]:
    """Stream servoL for `stream_s` s, then time `repeats` moveL and stopL acknowledgements."""
    with EmulatorProcess("drivers.emulators.ur", ["--host", host, *args]):
        # latency is measured here, not link supervision: a busy machine must not end the stream
        arm = UrArm(UrConfig(host, watchdog_hz=0.0, link_timeout=10.0), WallClock(0.01))
        try:
            start = arm.pose()
            before = backdoor.call(host, 30999, "state")["servo_updates"]
            latencies = arm.stream_servo(lambda t: start + [0.01 * np.sin(t), 0, 0, 0, 0, 0], stream_s)
            s = backdoor.call(host, 30999, "state")
            received = s["servo_updates"] - before
            rate = (received - 1) / (s["servo_last"] - s["servo_first"])
            rows = [_stats(label, "servoL (streaming)", latencies, rate),
                    Row(label, "nominal controller rate", 0, float("nan"), float("nan"), arm.control_rate)]
            moves, stops = [], []
            for i in range(repeats):
                target = start + [0.0005 * (i % 2), 0, 0, 0, 0, 0]
                t0 = time.perf_counter()
                arm.move_linear(target, 0.25)
                moves.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                arm.stop()
                stops.append(time.perf_counter() - t0)
            rows += [_stats(label, "moveL async (acknowledged)", moves),
                     _stats(label, "stopL (completed)", stops)]
        finally:
            arm.close()
    return rows


def write_outputs(rows: list[Row], out_dir: Path) -> list[Path]:
    """CSV, Markdown table and a PNG chart of the rows."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path, md_path, png_path = out_dir / "drivers.csv", out_dir / "drivers.md", out_dir / "drivers.png"
    with csv_path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["controller", "measure", "n", "median_ms", "p99_ms", "rate_hz"])
        for r in rows:
            w.writerow([r.controller, r.measure, r.n, f"{r.median_ms:.4f}", f"{r.p99_ms:.4f}",
                        "" if r.rate_hz is None else f"{r.rate_hz:.1f}"])
    lines = ["| controller | measure | n | median (ms) | p99 (ms) | rate (Hz) |", "|---|---|---|---|---|---|"]
    for r in rows:
        lat = ("-", "-") if r.n == 0 else (f"{r.median_ms:.3f}", f"{r.p99_ms:.3f}")
        lines.append(f"| {r.controller} | {r.measure} | {r.n or '-'} | {lat[0]} | {lat[1]} | "
                     f"{'-' if r.rate_hz is None else f'{r.rate_hz:.1f}'} |")
    md_path.write_text("# UR driver through ur_rtde to the loopback emulator\n\n" + "\n".join(lines) + "\n")

    timed = [r for r in rows if r.n]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 4.5), gridspec_kw={"width_ratios": [1.6, 1]})
    labels = [f"{r.measure}, {r.controller}" for r in timed]
    y = np.arange(len(timed))
    ax1.barh(y - 0.2, [r.median_ms for r in timed], 0.4, label="median")
    ax1.barh(y + 0.2, [r.p99_ms for r in timed], 0.4, label="p99")
    ax1.set_yticks(y, labels, fontsize=8)
    ax1.invert_yaxis()
    ax1.set_xlabel("call latency (ms, log scale)")
    ax1.set_xscale("log")
    ax1.legend()
    ax1.set_title("command latency through the driver")
    controllers = sorted({r.controller for r in rows})
    achieved = [next(r.rate_hz for r in rows if r.controller == c and r.n) for c in controllers]
    nominal = [next(r.rate_hz for r in rows if r.controller == c and not r.n) for c in controllers]
    xc = np.arange(len(controllers))
    ax2.bar(xc - 0.2, nominal, 0.4, label="controller rate")
    ax2.bar(xc + 0.2, achieved, 0.4, label="servoL received (emulator clock)")
    ax2.set_xticks(xc, controllers)
    ax2.set_ylabel("Hz")
    ax2.legend(loc="lower center")
    ax2.set_title("servo streaming rate")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)
    return [csv_path, md_path, png_path]


def run(out_dir: Path, quick: bool = False) -> list[Path]:
    """Run the benchmark; returns the files written."""
    controllers = dict(list(CONTROLLERS.items())[:1]) if quick else CONTROLLERS
    rows: list[Row] = []
    for label, (host, args) in controllers.items():
        rows += bench_controller(label, host, args, stream_s=1.0 if quick else 3.0,
                                 repeats=50 if quick else 200)
    paths = write_outputs(rows, Path(out_dir))
    print(paths[1].read_text())
    return paths


if __name__ == "__main__":
    raise SystemExit(script("python -m assembly.bench.drivers", run, "bench/drivers", "e-Series only, shorter runs",
                            __doc__.split("\n\n")[0]))
