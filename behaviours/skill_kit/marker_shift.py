"""A force change read marker by marker: each tracked marker's force (`perception.wrench.marker_forces`)
against its own reference, averaged over the markers tracked now.

Why: the pipeline's force is the mean over whichever markers are tracked on a frame. Under a firm
grip the markers are spread by several px (0.17 px per N of normal load on a real skin), unevenly,
so a marker lost or found moves that mean by a few tenths of a px (0.34 px rms measured on the
stir scene's grasp in signals mode) while the skin did not move; per-marker changes do not see it
(0.008 px rms there). Skills that look for small changes on a loaded fingertip use this."""

from __future__ import annotations

import numpy as np

from perception.state import TactileState
from perception.wrench import marker_forces


class MarkerShift:
    """The change of the hand's force (finger convention, summed over both fingers, px) since the
    reference ticks given to `add_reference`."""

    def __init__(self) -> None:
        self._sum: dict[str, np.ndarray] = {}
        self._count: dict[str, np.ndarray] = {}
        self._reference: dict[str, np.ndarray] | None = None

    def add_reference(self, *states: TactileState) -> None:
        """Add one tick of the fingertips (at rest) to the references."""
        for state in states:
            force = marker_forces(state.markers, state.finger)
            valid = np.asarray(state.markers.valid, bool)
            if state.finger not in self._sum or len(self._sum[state.finger]) != len(force):
                self._sum[state.finger] = np.zeros_like(force)
                self._count[state.finger] = np.zeros(len(force))
            self._sum[state.finger][valid] += force[valid]
            self._count[state.finger][valid] += 1
        self._reference = None

    def change(self, *states: TactileState) -> np.ndarray:
        """(3,) summed over `states`' fingers: the mean over markers tracked now (and in the reference)
        of their force's change since the reference; a finger recalibrated since (another marker
        count) adds nothing."""
        if self._reference is None:
            self._reference = {f: np.where(self._count[f][:, None] > 0,
                                           self._sum[f] / np.maximum(self._count[f], 1)[:, None], np.nan)
                               for f in self._sum}
        total = np.zeros(3)
        for state in states:
            reference = self._reference.get(state.finger)
            force = marker_forces(state.markers, state.finger)
            if reference is None or len(reference) != len(force):
                continue
            use = np.asarray(state.markers.valid, bool) & np.isfinite(reference[:, 0])
            if use.any():
                total += (force[use] - reference[use]).mean(axis=0)
        return total


def hand_axes(change: np.ndarray) -> np.ndarray:
    """A summed finger-convention force as the force on the hand along tool [x, y, z] (as
    `hand.hand_force`)."""
    return np.array([change[0], -change[1], -change[2]])
