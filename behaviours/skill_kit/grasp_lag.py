"""How far the fingers closed past the touch because the skin showed it late, measured on the spot.

A viscoelastic skin shows a load over its time constant tau, so fingers closing at speed v feel the
touch only after they have pressed on: `gentle_grasp` then squeezes from there and grips far
firmer than its margin says (15-40 N instead of ~10 N on a 0.9 s skin), which is what deforms the
gel so much that the cameras lose markers. With the fingers stopped where the touch was felt, the
reading (markers' mean motion) relaxes to what the grip really puts on the skin; `skill_kit.settle`
measures that and tau from the decay. For a linear skin pressed at a constant speed from the true
touch t s before the stop, the reading shown is F ~ k v (t - tau (1 - e^(-t/tau))) and the settled
one S ~ k v t, so S / F fixes t; a skin answering at once would have shown F after closing t F / S,
so the fingers are v t (1 - F / S) further closed than such a skin would have left them; the squeeze
was tuned on the sensor profile's skin (whose lag left them v (t0 - t F / S) past, t0 likewise), so
the difference is taken back. The skin's time constant and gain come from the readings; only the
tuned skin's lag is read from the profile.
"""

from __future__ import annotations

import math


def pressed_time(ratio: float, lag: float) -> float:
    """s between the true touch and the stop, for a settled-over-shown reading `ratio` (> 1) of a
    first-order skin of time constant `lag` (> 0) pressed at a constant speed: the root of
    t / (t - lag (1 - e^(-t/lag))) = ratio (the left side falls from infinity at t = 0 to 1)."""
    if ratio <= 1.0 or lag <= 0.0:
        raise ValueError(f"need a ratio above 1 and a positive lag, got {ratio} and {lag}")

    def shown(t: float) -> float:  # the shown reading over the settled one, rising from 0 to 1 with t
        return 1.0 - lag * (1.0 - math.exp(-t / lag)) / t

    lo, hi = 1e-9 * lag, lag
    while shown(hi) < 1.0 / ratio:  # bracket the root
        hi *= 2.0
        if hi > 1e6 * lag:
            return hi
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if shown(mid) < 1.0 / ratio else (lo, mid)
    return 0.5 * (lo + hi)


def _fired_at(pressed: float, lag: float) -> float:
    """s after the true touch at which a first-order skin of time constant `lag` pressed at a constant
    speed shows what a skin answering at once shows after `pressed` s: the root of
    t - lag (1 - e^(-t/lag)) = pressed (the left side rises from 0 with slope up to 1)."""
    if lag <= 0.0:
        return pressed
    lo, hi = pressed, pressed + lag
    while hi - lag * (1.0 - math.exp(-hi / lag)) < pressed:
        hi += lag
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mid - lag * (1.0 - math.exp(-mid / lag)) < pressed else (lo, mid)
    return 0.5 * (lo + hi)


def overshoot(shown: float, settled: float, lag: float | None, speed: float, tuned_lag: float = 0.0) -> float:
    """m the fingers closed past where a skin of time constant `tuned_lag` (the sensor profile's: the
    skin the grasp's squeeze was tuned on) would have stopped them: the reading `shown` when they
    stopped, `settled` once the skin has shown all of the grip, the skin's measured time constant
    `lag` (s; None: no decay measured) and the closing `speed` (m/s). 0 when the skin showed no more
    after the stop than when it fired, no lag was measured, or it is no slower than `tuned_lag`."""
    if lag is None or lag <= tuned_lag or shown <= 0.0 or settled <= shown:
        return 0.0
    t = pressed_time(settled / shown, lag)
    at_once = t * shown / settled  # s an instant skin needed to show `shown`
    return max(0.0, speed * (t - _fired_at(at_once, tuned_lag)))
