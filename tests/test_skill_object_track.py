"""object_track: the proximity-vision rule tick by tick, and on the FollowMe scene, where it
follows along the pads but is blind along the fingers' closing axis."""

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


def followme(axis: str) -> dict:
    cell = load_cell("sim", 30, "followme", {"axis": axis, "direction": "pull"})
    h = TreeHarness.from_file("trees/object_track.yaml", cell=cell)
    assert h.run_until_done(1000).name == "SUCCESS"
    return cell.world.metrics()


def test_object_track_follows_along_the_pads_but_not_along_the_closing_axis():
    assert followme("x")["tracking error final (mm)"] < 5.0
    blind = followme("y")
    assert blind["tracking error final (mm)"] > 100.0  # the person led 120 mm; the view never changed
    assert blind["peak force on the block (N)"] == pytest.approx(25.0)  # the person pushed in vain
