"""What the tick loop hands back when a run ends: its status, where and why it ended, how long
it took in cell and wall time, and the load profiles it measured."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class RunResult:
    status: str  # SUCCESS | FAILURE | HALTED | ESTOP | TIMEOUT | FAULT | CRASHED
    ticks: int
    sim_time: float
    wall_time: float
    where: str  # node path where the run ended or stopped
    message: str = ""
    profiles: dict[str, dict] = field(default_factory=dict)  # element -> load profile
    traceback: str = ""  # CRASHED: where the exception came from
    margins: dict[str, dict[str, float]] = field(default_factory=dict)  # the supervisor's worst figures

    @property
    def real_time_factor(self) -> float:
        return self.sim_time / self.wall_time if self.wall_time > 0 else float("inf")
