"""object_track: the proximity-vision rules tick by tick (centroid along the pads, the paper's
area rule with Delta and M_eps along the closing axis), and on the FollowMe scene along every
axis."""

from __future__ import annotations

import numpy as np
import pytest

from assembly.testing import TreeHarness, touch
from drivers.cell_builders import load_cell


def one_skill(params: str = "{}") -> TreeHarness:
    return TreeHarness.from_text(f"version: 1\nname: t\nroot: {{skill: object_track, name: s, params: {params}}}\n")


def seen(cx: float = 0.0, cz: float = 0.0, area: float = 0.3) -> dict:
    """Block seen shifted by cx along tool x and cz along tool z (image fractions)."""
    return {"left": touch("left", normal=5.0, area=area, centroid=(-cx, cz)),
            "right": touch("right", normal=5.0, area=area, centroid=(cx, cz))}


def test_object_track_steps_towards_the_offset_and_ignores_the_dead_band():
    h = one_skill("{duration: 1.0, gain: 0.02, eps: 0.02}")
    h.script(lambda tick, t: seen(cx=0.01 if tick < 10 else 0.08, cz=-0.3))
    assert h.run_until_done(100).name == "SUCCESS"
    twists = np.array([c.args[0] for c in h.arm.commands_named("speed_linear")])
    assert twists[0][0] == 0.0  # 0.01 is inside the dead band
    assert twists[-1][0] == pytest.approx(0.08 * 0.02 * 30)  # step per tick -> m/s
    assert twists[-1][2] == pytest.approx(0.1 * 0.02 * 30)  # clipped at max_offset, tool z = base -z


def test_object_track_fails_when_the_object_leaves_the_view():
    h = one_skill()
    h.script([(0, seen()), (15, seen(area=0.001))])
    assert h.run_until_done(100).name == "FAILURE"
    assert "lost the object" in h.feedback("s")


def test_object_track_halted_stops_the_arm():
    h = one_skill("{duration: 0}")
    h.script(lambda tick, t: seen(cx=0.1))
    h.tick(5)
    assert h.arm.is_moving()
    h.halt()
    assert not h.arm.is_moving()


def pressed(left_area: float) -> dict:
    """The block pressed into the left pad (bigger there) or off it (smaller)."""
    return {"left": touch("left", normal=5.0, area=left_area), "right": touch("right", normal=5.0, area=0.3)}


def test_object_track_steps_delta_along_the_closing_axis_by_the_left_pads_area():
    h = one_skill("{duration: 1.0, delta: 0.001, m_eps: 0.3, area_band: 0.05}")
    h.script(lambda tick, t: pressed(0.3 if tick < 5 else 0.2 if tick < 15 else 0.4))
    assert h.run_until_done(100).name == "SUCCESS"
    tool_y = -np.array([c.args[0][1] for c in h.arm.commands_named("speed_linear")])  # tool y = base -y
    assert np.allclose(tool_y[:4], 0.0)  # M_t = M_eps: inside the dead band, still
    assert np.allclose(tool_y[6:14], 0.001 * 30)  # M_t <= M_eps: off the left pad, +Delta per tick
    assert np.allclose(tool_y[16:], -0.001 * 30)  # M_t > M_eps: into the left pad, -Delta per tick


def test_object_track_takes_m_eps_from_the_start():
    h = one_skill("{duration: 0.5}")
    h.script(lambda tick, t: pressed(0.25 if tick < 3 else 0.2))
    assert h.run_until_done(100).name == "SUCCESS"
    assert -h.arm.commands_named("speed_linear")[-1].args[0][1] == pytest.approx(0.0015 * 30)


def followme(axis: str, direction: str = "pull") -> dict:
    cell = load_cell("sim", 30, "followme", {"axis": axis, "direction": direction})
    h = TreeHarness.from_file("trees/object_track.yaml", cell=cell)
    assert h.run_until_done(1000).name == "SUCCESS"
    return cell.world.metrics()


@pytest.mark.parametrize("direction", ["pull", "push"])
def test_object_track_follows_along_the_pads_and_the_closing_axis(direction):
    assert followme("x", direction)["tracking error final (mm)"] < 5.0
    closing = followme("y", direction)  # the person leads 120 mm across the pads
    assert closing["tracking error rms (mm)"] < 15.0 and closing["tracking error final (mm)"] < 10.0
    assert closing["peak force on the block (N)"] < 10.0 and not closing["block lost"]
