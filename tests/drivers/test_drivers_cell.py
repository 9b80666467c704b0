"""Cell files for real hardware: validation, building the emulated cell, `fvtree check`, the bench."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from drivers_testkit import emulating, next_host, tolerant_of_load

from assembly.bench import drivers as benchmark
from drivers.cell_builders import load_cell
from drivers.cell_file import CELLS_DIR, CellFileError, read_cell_file
from drivers.check import check_cell
from drivers.emulators.shadow import parse_shadow
from drivers.hardware.real_cell import parse
from drivers.hardware.ur import UrArm
from drivers.loopback import is_loopback
from drivers.safety import SafeArm
from perception.calibration import MarkerMap
from perception.config import FingerVisionConfig
from perception.state import FINGERS


@pytest.fixture
def emulated_cell(tmp_path):
    """emulated.yaml moved onto fresh test addresses, tolerant of a loaded machine, with its
    emulators running."""
    data = tolerant_of_load(yaml.safe_load((CELLS_DIR / "emulated.yaml").read_text()))
    data["arm"]["host"] = next_host()
    data["gripper"]["host"] = next_host()
    for finger in FINGERS:
        data["cameras"][finger]["source"] = f"http://{next_host()}:8080/stream.mjpg"
    path = tmp_path / "emulated.yaml"
    path.write_text(yaml.safe_dump(data))
    with emulating(path, object_width=0.04):
        yield path


def test_packaged_real_cell_files_validate_without_touching_hardware():
    for name in ("ur_robotiq", "emulated", "emulated_shadow"):
        path = CELLS_DIR / f"{name}.yaml"
        spec = (parse_shadow if name == "emulated_shadow" else parse)(path, read_cell_file(path))
        assert set(spec["cameras"]) == (set() if name == "emulated_shadow" else set(FINGERS))
        assert spec["limits"].max_speed <= 0.25
    spec = parse(CELLS_DIR / "ur_robotiq.yaml", read_cell_file(CELLS_DIR / "ur_robotiq.yaml"))
    assert spec["gripper"].framing == "rtu" and spec["gripper"].port == 54321
    assert spec["limits"].out_of_workspace == "refuse"


@pytest.mark.parametrize("edit, field, message", [
    (lambda d: d["arm"].update(hots="x"), "arm.hots", "unknown field"),
    (lambda d: d["gripper"].update(driver="onrobot"), "gripper.driver", "unsupported driver"),
    (lambda d: d["gripper"].update(framing="ascii"), "gripper", "framing"),
    (lambda d: d["safety"].update(max_speed=-1), "safety", "positive"),
    (lambda d: d.pop("arm"), "arm", "missing section"),
    (lambda d: d["perception"].update(source="fingervision"), "cameras", "needs cameras"),
    (lambda d: d["perception"].update(source="magic"), "perception.source", "unknown source"),
    (lambda d: d.update(robot={}), "robot", "unknown field"),
    # only emulators run faster than real time or take objects from a shadow world
    (lambda d: d["arm"].update(host="192.168.1.10"), "arm.host", "not a loopback address"),
    (lambda d: d["gripper"].update(host="10.0.0.7"), "gripper.host", "not a loopback address"),
    (lambda d: d["arm"].update(host="127.0.0.1.example"), "arm.host", "not a loopback address"),
    (lambda d: d["emulation"].update(time_scale=0), "emulation", "time_scale"),
    (lambda d: d["emulation"].update(speed=3), "emulation.speed", "unknown field"),
    (lambda d: d["perception"]["world"].update(frictoin=1), "perception.world.frictoin", "unknown field"),
])
def test_cell_file_errors_name_the_field(tmp_path, edit, field, message):
    data = yaml.safe_load((CELLS_DIR / "emulated_shadow.yaml").read_text())
    edit(data)
    path = tmp_path / "cell.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(CellFileError) as err:
        parse_shadow(path, read_cell_file(path))
    assert err.value.field == field and message in err.value.message


@pytest.mark.parametrize("host, loopback", [
    ("127.0.0.1", True), ("127.5.3.9", True), ("::1", True), ("localhost", True),
    ("127.0.0.1.example", False), ("127.example", False), ("0.0.0.0", False), ("192.168.1.10", False),
    ("", False), ("no-such-host.invalid", False),
])
def test_loopback_is_checked_on_the_address_not_on_a_prefix(host, loopback):
    assert is_loopback(host) is loopback


def test_a_cell_of_emulators_may_name_them_localhost(tmp_path):
    data = yaml.safe_load((CELLS_DIR / "emulated_shadow.yaml").read_text())
    data["arm"]["host"] = data["gripper"]["host"] = "localhost"
    path = tmp_path / "cell.yaml"
    path.write_text(yaml.safe_dump(data))
    assert parse_shadow(path, read_cell_file(path))["arm"].host == "localhost"


def _saved_map(tmp_path: Path, name: str, image_size=(320, 240), markers: int = 5) -> str:
    path = tmp_path / name
    MarkerMap(np.full((markers, 2), 50.0) + np.arange(markers)[:, None] * 20, np.full(markers, 8.0),
              image_size).save(path)
    return str(path)


def _parse_real(tmp_path: Path, edit) -> dict:
    """parse() of ur_robotiq.yaml after `edit`."""
    data = yaml.safe_load((CELLS_DIR / "ur_robotiq.yaml").read_text())
    edit(data)
    path = tmp_path / "cell.yaml"
    path.write_text(yaml.safe_dump(data))
    return parse(path, read_cell_file(path))


def test_real_cell_perception_is_loaded_while_parsing(tmp_path):
    left = _saved_map(tmp_path, "left.yaml")
    spec = _parse_real(tmp_path, lambda d: d["perception"].update(preset="thesis", marker_maps={"left": left}))
    perception = spec["perception"]
    assert isinstance(perception["config"], FingerVisionConfig) and perception["config"].name == "thesis"
    assert set(perception["maps"]) == {"left"} and len(perception["maps"]["left"]) == 5


@pytest.mark.parametrize("edit, field, message", [
    (lambda d, tmp: d["perception"].update(preset="fsat"), "perception.preset", "no perception preset 'fsat'"),
    (lambda d, tmp: d["perception"].update(preset=3), "perception.preset", "must be a preset name"),
    (lambda d, tmp: d["perception"].update(marker_maps={"left": str(tmp / "none.yaml")}),
     "perception.marker_maps.left", "no marker map file"),
    (lambda d, tmp: d["perception"].update(marker_maps={"lfet": _saved_map(tmp, "l.yaml")}),
     "perception.marker_maps.lfet", "unknown field"),
    (lambda d, tmp: d["perception"].update(marker_maps=[_saved_map(tmp, "l.yaml")]),
     "perception.marker_maps", "must map fingers"),
    (lambda d, tmp: d["perception"].update(marker_maps={"right": _saved_map(tmp, "r.yaml", markers=0)}),
     "perception.marker_maps.right", "no markers"),
    (lambda d, tmp: d["perception"].update(marker_maps={"right": _saved_map(tmp, "r.yaml", (640, 480))}),
     "perception.marker_maps.right", "camera right captures 320x240"),
    (lambda d, tmp: d["perception"].update(marker_maps={"left": str(CELLS_DIR / "sim.yaml")}),
     "perception.marker_maps.left", "not a marker map"),
    (lambda d, tmp: d["perception"].update(stale_after=0), "perception.stale_after", "positive"),
    (lambda d, tmp: d["perception"].update(calibration_timeout="5 s"), "perception.calibration_timeout", "positive"),
])
def test_real_cell_perception_errors_name_the_field(tmp_path, edit, field, message):
    with pytest.raises(CellFileError) as err:
        _parse_real(tmp_path, lambda d: edit(d, tmp_path))
    assert err.value.field == field and message in err.value.message
    assert err.value.line is not None


@pytest.mark.slow
def test_emulated_cell_builds_runs_perception_and_closes(emulated_cell):
    cell = load_cell(str(emulated_cell), 30.0, "assembly", {})
    try:
        assert isinstance(cell.arm, SafeArm) and isinstance(cell.arm.inner, UrArm)
        assert not cell.simulated and cell.gripper.fault() is None  # activated at start
        states = cell.sense()  # FingerVision pipeline on the emulated camera streams
        assert set(states) == set(FINGERS)
        assert all(s.finger == f for f, s in states.items())
        assert np.allclose(cell.arm.pose()[:3], [0.0, -0.4, 0.4])
        cell.arm.kick()
        cell.step()
        assert cell.arm.supervise() is None
    finally:
        cell.close()


@pytest.mark.slow
def test_check_reports_every_emulated_device_ok(emulated_cell):
    results = check_cell(str(emulated_cell))
    assert [name.split(" (")[0] for name, _, _ in results] == ["arm", "gripper", "camera left", "camera right"]
    assert all(ok for _, ok, _ in results), results


def test_check_reports_what_is_unreachable(tmp_path):
    data = yaml.safe_load((CELLS_DIR / "emulated.yaml").read_text())
    data["arm"]["host"], data["gripper"]["host"] = next_host(), next_host()
    data["cameras"] = {f: {"source": f"http://{next_host()}:8080/stream.mjpg", "open_timeout": 0.3}
                       for f in FINGERS}
    path = tmp_path / "down.yaml"
    path.write_text(yaml.safe_dump(data))
    results = check_cell(str(path))
    assert not any(ok for _, ok, _ in results)
    assert "connection refused" in results[0][2] and "cannot reach Robotiq" in results[1][2]


def test_check_of_a_bad_cell_file_is_a_located_error_before_any_device(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("kind: real\narm: {}\n")
    with pytest.raises(CellFileError) as err:
        check_cell(str(path))
    assert str(err.value) == f"{path}: safety: missing section" and err.value.exit_code == 2


@pytest.mark.slow
def test_drivers_benchmark_writes_table_and_chart(tmp_path):
    paths = benchmark.run(tmp_path, quick=True)
    assert [p.name for p in paths] == ["drivers.csv", "drivers.md", "drivers.png"]
    table = Path(paths[1]).read_text()
    assert "servoL (streaming)" in table and "moveL async" in table
    assert all(p.stat().st_size > 0 for p in paths)
