"""The load-profile chart of a run: per element, the load felt along its plate, the smoothing,
the chosen point and (in simulation) the true load curve."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from assembly.outcome.summary import CURVE
from drivers.protocols import World


def plot_profiles(profiles: dict[str, dict], world: World | None, path: Path) -> Path | None:
    """One panel per element: measured load along the plate, smoothing, chosen point and, from
    the world's truth, the true load curve and its maximum."""
    if not profiles:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    truth = world.truth() if world is not None else {}
    fig, axes = plt.subplots(len(profiles), 1, figsize=(8, 3.2 * len(profiles)), squeeze=False)
    for ax, (eid, prof) in zip(axes[:, 0], profiles.items()):
        x = np.asarray(prof["position"])
        ax.plot(x, prof["load"], ".", ms=2, color="0.6", label="measured (FingerVision)")
        ax.plot(x, prof["smoothed"], color="C0", label="smoothed")
        ax.axvline(prof["best_position"], color="C0", ls="--", label=f"chosen {prof['best_position']:.3f} m")
        ax.set_ylabel("load in the grip [px]")
        if CURVE in truth.get(eid, {}):
            curve = truth[eid][CURVE]
            shown = (curve["position"] >= x.min()) & (curve["position"] <= x.max())
            twin = ax.twinx()
            twin.plot(curve["position"][shown], curve["load_N"][shown], color="C3", lw=1, label="true R(a) [N]")
            twin.set_ylabel("true load as placed [N]", color="C3")
            ax.axvline(truth[eid]["true_best_position"], color="C3", ls=":",
                       label=f"true max {truth[eid]['true_best_position']:.3f} m")
        ax.set_title(f"{eid}: load along plate {prof.get('plate', '')}")
        ax.set_xlabel("position along the span a [m]")
        ax.legend(loc="lower center", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
