"""The compiled loops of the tracker, the Kalman filter, the wrench and the signals-mode sensor: the
same answers as plain linear algebra and numpy, and loaded when a sensor is set up (a first frame or
tick never compiles)."""

import numpy as np
from conftest import Scene

from drivers.sim.models import sensor_kernels
from drivers.sim.models.fingervision_model import FingerContact, SensorModel
from perception import sums, tracking_kernels, wrench, wrench_kernel
from perception.marker_tracking import LocalFit, neighbour_index
from perception.state import MarkerField
from perception.wrench import marker_forces, marker_levers

KERNELS = [tracking_kernels.measure_windows, tracking_kernels.predict_local, tracking_kernels.near_trusted,
           tracking_kernels.kalman_step, tracking_kernels.moving_hoods, wrench_kernel.mean_wrench,
           sensor_kernels.marker_field, sensor_kernels.observe, sums.pairwise_sum]


def signatures() -> list[int]:
    return [len(kernel.signatures) for kernel in KERNELS]


def test_local_fit_with_untrusted_neighbours_is_the_weighted_least_squares_solution():
    rng = np.random.default_rng(5)
    origin = rng.uniform(0, 200, (30, 2))
    fit = LocalFit(origin, neighbour_index(origin, 6), ridge=0.5)
    displacement = rng.normal(0, 3, (30, 2))
    trusted = rng.random(30) < 0.6
    predicted, count = fit.predict(displacement, trusted)
    for i, neighbours in enumerate(fit.neighbours):
        use = trusted[neighbours]
        assert count[i] == use.sum()
        x = fit._x[i][use]  # rows [1, relative origin / spacing] of the trusted neighbours
        normal = x.T @ x + np.diag([1e-9, 0.5, 0.5])
        expected = np.linalg.solve(normal, x.T @ displacement[neighbours][use])[0]
        assert np.allclose(predicted[i], expected, atol=1e-9)


def test_mean_wrench_is_the_average_of_the_per_marker_forces_and_torques():
    rng = np.random.default_rng(2)
    origin = rng.uniform(20, 300, (25, 2))
    markers = MarkerField(origin, origin + rng.normal(0, 2, origin.shape), np.full(25, 9.0), np.full(25, 9.0),
                          rng.random(25) < 0.8)
    for finger in ("left", "right"):
        force, torque = wrench.wrench(markers, finger)
        f = marker_forces(markers, finger)[markers.valid]
        p = marker_levers(markers, finger)[markers.valid]
        lever = np.column_stack([p[:, 0], np.zeros(len(p)), p[:, 1]])
        assert np.allclose(force, f.mean(axis=0), atol=1e-12)
        assert np.allclose(torque, np.cross(lever, f).mean(axis=0), atol=1e-12)


def test_a_pipeline_made_has_loaded_every_kernel_its_frames_use():
    scene = Scene(noise=2.0)
    fv = scene.pipeline("fast")  # warms the kernels up when it is made
    loaded = signatures()
    for image, _ in scene.press(frames=12, peak=60.0):  # markers move: follow, refind and the motion gate run
        fv.process(image, 0.0)
    assert signatures() == loaded


def test_a_signals_mode_sensor_made_has_loaded_its_kernels():
    sensor = SensorModel("left", pipeline_errors=True)
    loaded = signatures()
    for load in (0.0, 5.0, 20.0):
        sensor.state(FingerContact(normal=load, shear=np.array([0.2, 0.1]) * load), 0.0)
    assert signatures() == loaded


def test_the_compiled_sum_adds_in_numpys_order():
    rng = np.random.default_rng(3)
    for n in (1, 7, 8, 9, 70, 128, 129, 300, 1000, 5000):
        values = rng.random(n) * rng.choice([1.0, 1e-3, 1e5], n)
        assert sums.pairwise_sum(values, 0, n) == np.add.reduce(values)


def test_the_error_models_marker_step_is_the_numpy_one():
    rng = np.random.default_rng(4)
    exact, prev, estimate = rng.random((37, 3)), rng.random((37, 3)), rng.random((37, 3))
    tracked, noise = rng.random(37) >= 0.2, rng.normal(0, 0.04, (37, 3))
    markers = MarkerField(rng.uniform(20, 300, (37, 2)), image_size=(320, 240))
    terms = wrench.wrench_terms(markers, "right")
    for alpha in (1.0, 0.4):
        step = estimate.copy()
        position, size, out = np.full((37, 2), np.nan), np.full(37, np.nan), np.full(6, np.nan)
        moved = sensor_kernels.observe(exact, prev, step, tracked, noise, alpha, markers.origin, terms, position, size,
                                       out)
        force, torque = out[:3], out[3:]
        kept = np.where(tracked[:, None], estimate + alpha * (exact - estimate) if alpha < 1.0 else exact, estimate)
        assert np.array_equal(step, kept)
        assert np.array_equal(position, kept[:, :2] + noise[:, :2]) and np.array_equal(size, kept[:, 2] + noise[:, 2])
        assert moved == np.add.reduce(np.abs(exact[:, :2] - prev[:, :2]), axis=None) / 74
        reported = MarkerField(markers.origin, position, valid=tracked, image_size=(320, 240))
        expected = wrench.wrench(reported, "right")
        assert np.array_equal(force, expected[0]) and np.array_equal(torque, expected[1])
