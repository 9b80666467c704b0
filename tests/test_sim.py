"""The simulated cell's models against closed-form and worked-out figures."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.clock import SimClock
from drivers.sim.devices.arm import KinematicArm
from drivers.sim.devices.gripper import SimGripper
from drivers.sim.models.plate import BeamPlate
from drivers.sim.transforms import matrix_to_rotvec, rotvec_to_matrix


def test_plate_finds_the_maximum_of_the_toy_scene():
    # L = 1, EI = 50, w = 100, k = 2000, P = 40 at 0.7: R(a) peaks at 43.1 N, 0.568 m from the left
    plate = BeamPlate(span=1.0, EI=50.0, w=100.0, P=40.0, c=0.7, k=2000.0)
    a, r = plate.max_load(clearance=0.0)
    assert a == pytest.approx(0.568, abs=0.001) and r == pytest.approx(43.1, abs=0.05)


def test_rigid_prop_at_midspan_carries_five_eighths_of_the_load():
    plate = BeamPlate(span=2.0, EI=80.0, w=50.0, P=0.0, k=1e12)
    assert plate.carried_force(1.0, 0.0) == pytest.approx(5 * 50.0 * 2.0 / 8, rel=1e-6)


def test_uniform_load_midspan_deflection():
    plate = BeamPlate(span=1.5, EI=60.0, w=70.0, P=0.0)
    assert plate.deflection(0.75) == pytest.approx(5 * 70.0 * 1.5**4 / (384 * 60.0))


def test_no_load_where_the_clearance_is_not_closed():
    plate = BeamPlate()
    assert plate.carried_force(0.02, 0.02) == 0.0


def test_arm_moves_at_the_commanded_speed_and_stops_on_target():
    clock = SimClock(0.01)
    arm = KinematicArm(clock, [0, 0, 0.5, np.pi, 0, 0])
    arm.move_linear(np.array([0.1, 0, 0.5, np.pi, 0, 0]), 0.05)
    for _ in range(100):
        arm.step(0.01)
    assert arm.pose()[0] == pytest.approx(0.05)
    for _ in range(101):
        arm.step(0.01)
    assert arm.pose()[0] == pytest.approx(0.1) and not arm.is_moving()


def test_arm_caps_commanded_speed():
    arm = KinematicArm(SimClock(0.1), [0, 0, 0.5, 0, 0, 0], max_speed=0.2)
    arm.speed_linear(np.array([1.0, 0, 0, 0, 0, 0]))
    arm.step(0.1)
    assert arm.pose()[0] == pytest.approx(0.02)


def test_gripper_settles_where_the_gel_squeeze_matches_the_force():
    g = SimGripper(max_width=0.085, gel_stiffness=5000.0)
    g.object_width = 0.04
    g.move(0.0, speed=0.1, force=20.0)
    for _ in range(200):
        g.step(0.01)
    assert g.object_detected() and g.squeeze_force() == pytest.approx(20.0)
    assert g.width() == pytest.approx(0.04 - 20.0 / 5000.0)


def test_rotation_helpers_round_trip():
    rng = np.random.default_rng(3)
    for r in [*rng.normal(size=(50, 3)), np.array([np.pi, 0, 0]), np.array([0, -np.pi / 2, 0])]:
        m = rotvec_to_matrix(r)
        assert np.allclose(m @ m.T, np.eye(3))
        assert np.allclose(rotvec_to_matrix(matrix_to_rotvec(m)), m, atol=1e-7)


# ---- signals mode: the real pipeline's measured errors (drivers/sim/models/pipeline_error_model.py) ----

def _held(shear=(0.0, 0.0), slip: float = 0.0):
    from drivers.sim.models.fingervision_model import FingerContact
    from perception.state import ObjectInfo

    return FingerContact(10.0, np.array(shear, float), 0.0, None, ObjectInfo(True, 0.3, np.zeros(2), 0.0), slip)


def _errors_model(seed: int = 1):
    from drivers.sim.models.fingervision_model import SensorModel

    return SensorModel("left", seed=seed, pipeline_errors=True), SensorModel("left", noise_px=0.0)


def test_signals_mode_markers_jitter_and_drop_out_as_the_pipeline_measured():
    from drivers.sim.models.pipeline_error_model import PipelineErrors

    e = PipelineErrors()
    model, exact = _errors_model()
    rest = [model.state(_held(), 0.0) for _ in range(400)]
    truth = exact.state(_held(), 0.0).markers.position
    tracked = np.stack([s.markers.valid for s in rest])
    jitter = np.concatenate([s.markers.position[s.markers.valid] - truth[s.markers.valid] for s in rest])
    assert np.std(jitter) == pytest.approx(e.noise_px, rel=0.15)
    lossy = tracked.mean(axis=0) < 0.9  # a few markers, fixed, are lost often; the others never
    assert lossy.mean() == pytest.approx(e.lossy_share, abs=0.1) and tracked[:, ~lossy].all()
    assert 1.0 - tracked[:, lossy].mean() == pytest.approx(e.lossy_rate, abs=0.08)


def test_the_error_model_lags_markers_as_a_first_order_filter():
    from drivers.sim.models.pipeline_error_model import ErrorModel, PipelineErrors
    from perception.state import MarkerField

    model = ErrorModel(PipelineErrors(lag_alpha=0.4, noise_px=0.0, lossy_share=0.0), np.random.default_rng(0),
                       MarkerField(np.zeros((3, 2))), "left")
    rest, moved = np.full((3, 3), 9.0), np.full((3, 3), 9.0)  # x, y, size per marker
    rest[:, :2], moved[:, :2] = 0.0, 2.0
    model.apply(_held(), rest)
    first = model.apply(_held(), moved)[0]
    assert first == pytest.approx(0.4 * moved[:, :2])
    for _ in range(20):
        last = model.apply(_held(), moved)[0]
    assert last == pytest.approx(moved[:, :2], abs=1e-3)


def test_signals_mode_object_and_slip_carry_the_pipeline_errors():
    from drivers.sim.models.pipeline_error_model import PipelineErrors

    e = PipelineErrors()
    model, _ = _errors_model(seed=2)
    still = [model.state(_held(), 0.0) for _ in range(300)]
    areas = np.array([s.obj.area for s in still])
    assert np.median(areas) == pytest.approx(e.area_scale * 0.3, rel=0.05) and areas.std() > 0.0
    assert np.median([s.slip for s in still]) < 0.01  # a held object at rest: only the floor
    sliding = [model.state(_held(slip=0.3), 0.0).slip for _ in range(300)]  # 1.2 px/frame of texture
    assert np.median(sliding) == pytest.approx(e.slip_gain * 0.3 * e.slip_saturation, rel=0.2)
    jitter = [model.state(_held((2.0 * (i % 2), 0.0)), 0.0).slip for i in range(300)]  # markers jump, no slip
    assert np.median(jitter) > 10 * np.median([s.slip for s in still])  # MOG2 sees markers move, too


def test_signals_mode_errors_are_seeded():
    a, _ = _errors_model(seed=5)
    b, _ = _errors_model(seed=5)
    for i in range(20):
        sa, sb = a.state(_held((i * 0.1, 0.0), slip=0.1), 0.0), b.state(_held((i * 0.1, 0.0), slip=0.1), 0.0)
        assert np.array_equal(sa.markers.position, sb.markers.position) and sa.slip == sb.slip
        assert sa.obj.area == sb.obj.area


def test_the_simulated_cell_applies_the_errors_in_signals_mode_only_unless_turned_off(tmp_path):
    import yaml

    from drivers.cell_builders import load_cell
    from drivers.cell_file import resolve_cell_path

    def area(cell_file: str, perception: str = "signals") -> float:
        cell = load_cell(cell_file, 30, "hold", {}, perception=perception)
        try:
            return float(np.median([cell.sense()["left"].obj.area for _ in range(15)]))
        finally:
            cell.close()

    data = yaml.safe_load(resolve_cell_path("sim").read_text())
    data["sensor"]["pipeline_errors"] = False
    exact = tmp_path / "exact.yaml"
    exact.write_text(yaml.safe_dump(data))
    assert area(str(exact)) == 0.3  # the scene's own view of the box
    assert area("sim") == pytest.approx(0.66 * 0.3, rel=0.1)
    assert area("sim", "pixels") == pytest.approx(0.66 * 0.3, rel=0.15)  # what the error model stands for
