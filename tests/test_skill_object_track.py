"""object_track: the proximity-vision rules tick by tick (centroid along the pads, the paper's
area rule with Delta and M_eps along the closing axis), and on the FollowMe scene along every
axis."""

from __future__ import annotations

from pathlib import Path

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
    h.tick(15)  # 10 reference ticks, then following
    assert h.arm.is_moving()
    h.halt()
    assert not h.arm.is_moving()


def pressed(left_area: float) -> dict:
    """The block pressed into the left pad (bigger there) or off it (smaller)."""
    return {"left": touch("left", normal=5.0, area=left_area), "right": touch("right", normal=5.0, area=0.3)}


def test_object_track_steps_delta_along_the_closing_axis_by_the_left_pads_area():
    h = one_skill("{duration: 1.0, delta: 0.001, m_eps: 0.3, area_band: 0.05, reference_ticks: 1}")
    h.script(lambda tick, t: pressed(0.3 if tick < 5 else 0.2 if tick < 15 else 0.4))
    assert h.run_until_done(100).name == "SUCCESS"
    tool_y = -np.array([c.args[0][1] for c in h.arm.commands_named("speed_linear")])  # tool y = base -y
    assert np.allclose(tool_y[:4], 0.0)  # M_t = M_eps: inside the dead band, still
    assert np.allclose(tool_y[6:14], 0.001 * 30)  # M_t <= M_eps: off the left pad, +Delta per tick
    assert np.allclose(tool_y[16:], -0.001 * 30)  # M_t > M_eps: into the left pad, -Delta per tick


def test_object_track_takes_m_eps_from_the_start():
    h = one_skill("{duration: 0.5, reference_ticks: 3}")
    h.script(lambda tick, t: pressed(0.25 if tick < 3 else 0.2))
    assert h.run_until_done(100).name == "SUCCESS"
    assert -h.arm.commands_named("speed_linear")[-1].args[0][1] == pytest.approx(0.0015 * 30)


def pads(left_normal: float, right_normal: float, left_area: float = 0.3) -> dict:
    """The block pushed along the closing axis: the pads' normal loads differ (N)."""
    return {"left": touch("left", normal=left_normal, area=left_area), "right": touch("right", normal=right_normal,
                                                                                     area=0.3)}


def test_object_track_fails_when_a_closing_axis_push_goes_unseen():
    """A 12 N push on the pads with the seen area inside its dead band: vision cannot see that axis."""
    h = one_skill("{duration: 3.0, closing_force: false, unseen_force: 8.0, unseen_time: 0.5, reference_ticks: 3}")
    h.script(lambda tick, t: pads(10.0, 10.0) if tick < 5 else pads(4.0, 16.0))
    assert h.run_until_done(200).name == "FAILURE"
    assert "vision cannot follow the axis perpendicular to the skin" in h.feedback("s")
    assert "+12.0 N" in h.feedback("s")  # the markers' reading, in newtons through the sensor profile
    assert not h.arm.is_moving()


@pytest.mark.parametrize("params, left_area", [("{duration: 1.0, closing_force: false, reference_ticks: 3}", 0.2),  # seen
                                               ("{duration: 1.0, axes: xz, closing_force: false, reference_ticks: 3}",
                                                0.3),  # y not followed
                                               ("{duration: 1.0, closing_force: false, unseen_force: 0, reference_ticks: 3}",
                                                0.3),  # check off
                                               ("{duration: 1.0, reference_ticks: 3}", 0.3)])  # followed by the push
def test_an_unseen_push_is_no_failure_when_seen_or_not_followed(params, left_area):
    h = one_skill(params)
    h.script(lambda tick, t: pads(10.0, 10.0) if tick < 5 else pads(4.0, 16.0, left_area))
    assert h.run_until_done(200).name == "SUCCESS"


def test_object_track_follows_a_push_the_area_does_not_show_by_the_pads_loads():
    """Area inside its dead band, the pads' loads 12 N apart: closing_force steps Delta along the push
    (right pad loaded: +y); a difference inside the measured noise and min_push moves nothing."""
    rng = np.random.default_rng(0)
    h = one_skill("{duration: 1.0, reference_ticks: 10}")
    h.script(lambda tick, t: pads(*(10.0 + rng.normal(0.0, 0.05, 2))) if tick < 15 else pads(4.0, 16.0))
    assert h.run_until_done(100).name == "SUCCESS"
    tool_y = -np.array([c.args[0][1] for c in h.arm.commands_named("speed_linear")])  # tool y = base -y
    assert np.allclose(tool_y[:4], 0.0) and np.allclose(tool_y[-10:], 0.0015 * 30)


def test_followme_shows_a_closing_axis_push_as_the_gel_brings_the_block_nearer():
    """The area a pad sees is the block's apparent size through the skin: (d_grasp / d)^2 with d the
    camera's distance to the block's face, camera_depth - load / pad_stiffness."""
    cell = load_cell("sim", 30, "followme", {"axis": "y"})
    try:
        scene, squeeze = cell.world, 10.0
        scene.gripper.squeeze_force = lambda: squeeze
        d = scene.camera_depth
        grasp = d - squeeze / scene.pad_stiffness
        assert scene.pressed_area(squeeze) == pytest.approx(scene.area)
        assert scene.pressed_area(squeeze + 5.0) == pytest.approx(scene.area * (grasp / (grasp - 5.0 / 5000.0)) ** 2)
        assert scene.pressed_area(squeeze - 5.0) / scene.area == pytest.approx(0.8975, abs=0.001)  # -2 % per N
        scene.pad_stiffness = 1e12  # a gel that does not compress: nothing to see
        assert scene.pressed_area(squeeze + 20.0) == pytest.approx(scene.area)
    finally:
        cell.close()


def followme(axis: str, direction: str = "pull", status: str = "SUCCESS", pad_stiffness: float | None = None,
             vision_only: bool = False) -> dict:
    cell = load_cell("sim", 30, "followme", {"axis": axis, "direction": direction})
    if pad_stiffness is not None:
        cell.world.pad_stiffness = pad_stiffness
    text = Path("trees/object_track.yaml").read_text()
    if vision_only:
        text = text.replace("duration: 8.0}", "duration: 8.0, closing_force: false}")
    h = TreeHarness.from_text(text, cell=cell)
    assert h.run_until_done(1000).name == status
    return {**cell.world.metrics(), "feedback": h.feedback("follow_me/follow")}


@pytest.mark.parametrize("direction", ["pull", "push"])
def test_object_track_follows_along_the_pads_and_the_closing_axis(direction):
    assert followme("x", direction)["tracking error final (mm)"] < 5.0
    closing = followme("y", direction)  # the person leads 120 mm across the pads; vision sees the gel compress
    assert closing["tracking error rms (mm)"] < 30.0 and closing["tracking error final (mm)"] < 10.0
    assert closing["peak force on the block (N)"] < 15.0 and not closing["block lost"]


def test_object_track_fails_on_the_closing_axis_when_the_gel_does_not_show_the_push():
    """A gel 8x stiffer than the simulated gripper's: the area changes too little; vision alone says so."""
    closing = followme("y", "pull", "FAILURE", pad_stiffness=40000.0, vision_only=True)
    assert "vision cannot follow the axis perpendicular to the skin" in closing["feedback"]


def test_object_track_follows_the_closing_axis_on_a_stiff_gel_by_the_pads_loads():
    """The same gel with closing_force (the default): the markers show what the area does not."""
    closing = followme("y", "pull", pad_stiffness=40000.0)
    assert closing["tracking error rms (mm)"] < 25.0 and closing["tracking error final (mm)"] < 10.0


def test_object_track_fails_when_the_camera_cannot_tell_the_object_from_its_background():
    """The pipeline's warning (perception/fingervision.py) on a healthy state: vision has nothing to follow."""
    from perception.state import OBJECT_UNRELIABLE, TactileState

    def warned(state, share):
        return TactileState(state.finger, state.stamp, state.markers, state.force, state.torque, state.obj,
                            state.slip, True, f"{OBJECT_UNRELIABLE} {share:.1%} of the empty view (...)")

    for share, status in ((0.1, "SUCCESS"), (0.2, "FAILURE")):  # the object covers 0.3: a third, two thirds
        h = one_skill("{duration: 1.0, reference_ticks: 3, max_false_object: 0.5}")
        h.script(lambda tick, t, share=share: seen() if tick < 5 else {"left": seen()["left"],
                                                                        "right": warned(seen()["right"], share)})
        assert h.run_until_done(200).name == status
    assert "the right camera cannot tell the object from its background" in h.feedback("s")
    assert "20.0% of the empty view for it, the object covers 30.0%" in h.feedback("s")
