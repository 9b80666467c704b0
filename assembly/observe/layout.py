"""The default layout of the viewer (a Rerun blueprint): the tree graph and its transitions on the
left; per finger the marker field with displacement arrows and the force, torque and slip traces
in the middle; the 3-D cell, the load profile and the arm's traces on the right."""

from __future__ import annotations

import rerun.blueprint as rrb

from perception.state import FINGERS


def _finger(finger: str) -> rrb.Vertical:
    return rrb.Vertical(
        rrb.Spatial2DView(origin=f"fv/{finger}/markers", name=f"{finger} markers"),
        rrb.TimeSeriesView(origin=f"fv/{finger}/force", name=f"{finger} force"),
        rrb.TimeSeriesView(origin=f"fv/{finger}/torque", name=f"{finger} torque"),
        rrb.TimeSeriesView(contents=[f"fv/{finger}/slip", f"fv/{finger}/health"], name=f"{finger} slip, health"),
        row_shares=[3, 1, 1, 1],
    )


def default_blueprint() -> rrb.Blueprint:
    """The layout a recording, a replay and the live view open with."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.GraphView(origin="tree/graph", name="tree"),
                rrb.TextLogView(contents=["tree/transitions", "events", "task/element"], name="transitions, events"),
                rrb.TextLogView(origin="tree/feedback", name="feedback"),
                rrb.TextLogView(contents=["commands/**"], name="commands"),
                row_shares=[4, 2, 2, 1],
            ),
            rrb.Horizontal(*(_finger(f) for f in FINGERS)),
            rrb.Vertical(
                rrb.Spatial3DView(origin="cell", name="cell"),
                rrb.Spatial2DView(origin="task/load_profile", name="load profile"),
                rrb.TimeSeriesView(contents=["robot/wrench", "gripper/**"], name="wrench, gripper"),
                row_shares=[3, 2, 2],
            ),
            column_shares=[3, 4, 3],
        ),
        rrb.TimePanel(timeline="cell_time"),
        collapse_panels=True,
    )
