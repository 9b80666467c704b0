"""How to run a tree: every choice `fvtree run` offers, typed and with its defaults, in one value
that the command line, the benchmarks, the dataset recorder and the test harness all hand to `Run`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from assembly.language.substitution import Rule
from assembly.observe import IMAGE_HZ

MARKS = ("placed", "planned")  # what a person may mark an element a stopped run left `placing`


@dataclass(frozen=True)
class LinkOptions:
    """The live design link over MQTT (`--bridge`): the broker, the name this cell goes by on it
    (default: the tree's name), whether a coordinator hands out the elements, the credentials
    file (login, TLS files, signing secret; else the environment: assembly.design.link.security),
    TLS files given on the command line, how long a coordinated cell may lose the link, and whether
    it may take part in a coordinated build without a signing secret."""

    url: str
    cell_name: str | None = None
    coordinated: bool = False
    credentials: Path | None = None
    tls_ca: Path | None = None
    tls_cert: Path | None = None
    tls_key: Path | None = None
    lost_after: float = 10.0  # s
    unsigned: bool = False  # coordinated without a signing secret (a private broker only)


@dataclass(frozen=True)
class RunOptions:
    """One run's settings.

    `runs_dir` None runs without a run directory: no transition log, ESTOP file, as-built file,
    event log or recording (a test harness, a data-collection run); `supervised` False leaves out
    the cell supervisor (a harness whose perception is scripted). `marks` ({element: placed|planned})
    records a person's check of elements a stopped run left being placed, when resuming."""

    cell: str = "sim"  # a cell file, or a packaged cell's name
    seed: int = 0
    perception: str | None = None  # simulated FingerVision: signals | pixels (None: the cell's own)
    scene: str | None = None  # a simulated scene other than the tree's `cell.scene`
    scene_args: Mapping[str, Any] = field(default_factory=dict)  # the scene's own args, over the design's
    realtime: bool = False  # simulated time paced to the wall clock
    max_time: float = 3600.0  # s of cell time before the run gives up (TIMEOUT)
    estop_at: float | None = None  # s of cell time at which to simulate an e-stop
    runs_dir: Path | None = Path("runs")
    resume: str | None = None  # a run directory, or "latest"
    marks: Mapping[str, str] = field(default_factory=dict)
    record: bool = True  # the Rerun recording in the run directory
    record_images: float = IMAGE_HZ  # camera frames per second of cell time in the recording (0: none)
    live: str | None = None  # a viewer's URL to stream the recording to
    plots: bool = True  # the load-profile chart
    quiet: bool = False  # no progress line and no summary on the terminal
    supervised: bool = True
    link: LinkOptions | None = None
    substitutions: tuple[Rule, ...] = ()
    groot2: tuple[str, int] | None = None  # (address, port) to serve the run to Groot2 on (`--groot2`)
