"""The vectorised per-marker Kalman filter: equal to the thesis' 5-state filter, smooths static
jitter, follows steps (with the innovation gate) and smooth motion (with the motion gate), holds
lost markers."""

from dataclasses import replace

import numpy as np
import pytest

from perception.config import KalmanConfig, load_config
from perception.kalman import MarkerKalman

DT = 1.0 / 15.0


def reference_filter(z, q=0.01, r=0.1, c=0.1, dt=DT):
    """Textbook Kalman filter with the thesis' 5x5 matrices, one marker, every frame measured."""
    a = np.eye(5)
    a[0, 1] = a[2, 3] = dt
    h = np.zeros((3, 5))
    h[0, 0] = h[1, 2] = h[2, 4] = 1.0
    x = np.array([z[0, 0], 0.0, z[0, 1], 0.0, z[0, 2]])
    p = c * np.eye(5)
    out = []
    for zk in z:
        x, p = a @ x, a @ p @ a.T + q * np.eye(5)
        k = p @ h.T @ np.linalg.inv(h @ p @ h.T + r * np.eye(3))
        x = x + k @ (zk - h @ x)
        p = (np.eye(5) - k @ h) @ p
        out.append(h @ x)
    return np.array(out)


def run(cfg, z_pos, z_size, valid=None, dt=DT):
    kf = MarkerKalman(cfg, dt, z_pos[0], z_size[0])
    valid = np.ones(z_size.shape, bool) if valid is None else valid
    out = [kf.update(p, s, v) for p, s, v in zip(z_pos, z_size, valid)]
    return np.array([o[0] for o in out]), np.array([o[1] for o in out])


def test_matches_the_full_five_state_filter_for_every_marker():
    rng = np.random.default_rng(0)
    frames, n = 40, 6
    pos = rng.normal(0, 1.0, (frames, n, 2)).cumsum(axis=0) + 100.0
    size = 9.0 + rng.normal(0, 0.2, (frames, n))
    got_pos, got_size = run(KalmanConfig(), pos, size)
    for i in range(n):
        ref = reference_filter(np.column_stack([pos[:, i], size[:, i]]))
        np.testing.assert_allclose(got_pos[:, i], ref[:, :2], atol=1e-9)
        np.testing.assert_allclose(got_size[:, i], ref[:, 2], atol=1e-9)


def static_and_step(noise=0.08, step=2.0, frames=120, n=40, at=80, seed=1):
    rng = np.random.default_rng(seed)
    truth = np.zeros((frames, n, 2))
    truth[at:, :, 0] = step
    return truth, truth + rng.normal(0, noise, truth.shape), np.full((frames, n), 9.0)


def jitter_and_lag(cfg, dt):
    truth, z, size = static_and_step()
    est, _ = run(cfg, z + 100.0, size, dt=dt)
    est -= 100.0
    jitter = (z[20:80] - truth[20:80]).std() / (est[20:80] - truth[20:80]).std()
    settled = np.abs(est[80:, :, 0] - 2.0).mean(axis=1) < 0.2  # within 10 % of the step
    return jitter, int(np.argmax(settled))


def test_fast_preset_cuts_static_jitter_3x_and_follows_a_step_within_two_frames():
    cfg = load_config("fast")
    jitter, lag = jitter_and_lag(cfg.kalman, 1.0 / cfg.camera_fps)
    assert jitter >= 3.0
    assert lag <= 2


def test_thesis_filter_smooths_but_lags_a_step():
    cfg = load_config("thesis")
    jitter, lag = jitter_and_lag(cfg.kalman, 1.0 / cfg.camera_fps)
    assert jitter > 2.0
    assert lag > 2  # without the gate a 2 px step is smoothed over several frames


def smooth_shear(frames=120, noise=0.07, seed=2):
    """A 7x7 marker grid (30 px pitch): still for 60 frames, then a shear growing smoothly (cosine
    ramp, up to 0.5 px per frame and 8 px at the top row) over 40 frames, then held; measurements
    with Gaussian noise. Returns (origin, truth, measurements)."""
    rng = np.random.default_rng(seed)
    origin = np.array([[x, y] for y in range(0, 210, 30) for x in range(0, 210, 30)], float) + 50.0
    ramp = 0.5 * (1.0 - np.cos(np.pi * np.clip((np.arange(frames) - 60) / 40.0, 0.0, 1.0)))
    shear = 8.0 * (origin[:, 1] - 50.0) / 180.0
    truth = origin[None].repeat(frames, 0)
    truth[:, :, 0] += ramp[:, None] * shear[None, :]
    return origin, truth, truth + rng.normal(0.0, noise, truth.shape)


def test_motion_gate_follows_smooth_shear_without_losing_the_static_smoothing():
    from perception.marker_tracking import neighbour_index
    origin, truth, z = smooth_shear()
    cfg = load_config("fast").kalman
    errors = {}
    for name, gate in (("plain", 0.0), ("motion", cfg.motion_gate)):
        kf = MarkerKalman(replace(cfg, motion_gate=gate), 1.0 / 30.0, origin, np.full(len(origin), 9.0),
                          neighbour_index(origin, 6))
        est = np.array([kf.update(zk, np.full(len(origin), 9.0), np.ones(len(origin), bool))[0] for zk in z])
        errors[name] = est - truth
    raw = z - truth
    rms = {k: float(np.sqrt((e[60:] ** 2).sum(axis=2).mean())) for k, e in {**errors, "raw": raw}.items()}
    assert rms["motion"] <= rms["raw"]  # no lag: no worse than no filter while the skin moves
    assert rms["plain"] > rms["raw"]  # without the gate the filter lags the shear
    jitter = raw[20:60].std() / errors["motion"][20:60].std()
    assert jitter >= 3.0


def test_unmeasured_markers_hold_their_estimate_and_trust_the_next_measurement_more():
    cfg = KalmanConfig()
    kf = MarkerKalman(cfg, DT, np.zeros((2, 2)), np.full(2, 9.0))
    for _ in range(5):
        kf.update(np.zeros((2, 2)), np.full(2, 9.0), np.ones(2, bool))
    for _ in range(10):
        pos, _ = kf.update(np.full((2, 2), 50.0), np.full(2, 9.0), np.array([True, False]))
    assert np.all(pos[1] == 0.0)  # never extrapolated while lost
    gain_lost = kf.p00[1] / (kf.p00[1] + cfg.measurement_noise)
    gain_tracked = kf.p00[0] / (kf.p00[0] + cfg.measurement_noise)
    assert gain_lost > gain_tracked


def test_restart_puts_markers_at_rest_at_the_given_position():
    kf = MarkerKalman(KalmanConfig(), DT, np.zeros((3, 2)), np.full(3, 9.0))
    for k in range(5):
        kf.update(np.full((3, 2), float(k)), np.full(3, 9.0), np.ones(3, bool))
    which = np.array([False, True, False])
    kf.restart(which, np.full((3, 2), 7.0), np.full(3, 8.0))
    assert np.all(kf.pos[1] == 7.0) and np.all(kf.vel[1] == 0.0) and kf.size[1] == 8.0
    assert np.all(kf.vel[0] != 0.0)


def test_time_step_must_be_positive():
    with pytest.raises(ValueError, match="time step must be positive"):
        MarkerKalman(KalmanConfig(), 0.0, np.zeros((1, 2)), np.ones(1))
