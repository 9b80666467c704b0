"""Carry the held, upright element to beside the plate it must prop, at the start of the span
to search, with its foot a set height above the ground: over what lies low on the table and
around every plate and standing element, never under a plate (its sag is unknown), on the first
clear side of the target plate (-y, +y, then the end nearer the start of the search)."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.transit import NoPath, other_elements, plate_box, plate_of, transit_path


def approach_points(plate: dict, at: float, side: float) -> list[tuple[str, np.ndarray]]:
    """Where the element may stand beside `plate` to slide in under it at `at` of its span: beside
    its -y and +y edges, then beyond the end nearer `at`."""
    x0, y0 = float(plate["origin"][0]), float(plate["origin"][1])
    span, half = float(plate["span"]), float(plate["width"]) / 2.0
    x = x0 + at * span
    end = x0 - side if at <= 0.5 else x0 + span + side
    return [("-y side", np.array([x, y0 - half - side])), ("+y side", np.array([x, y0 + half + side])),
            ("end", np.array([end, y0]))]


@register
class ApproachPlate(ProgramSkill):
    NAME = "approach_plate"
    SUMMARY = "bring the upright element beside its plate at the start of the search span, around plates"
    PARAMS = {
        "at": Param("float", "position along the span where the search starts", 0.1, "fraction of span", min=0.0, max=1.0),
        "side": Param("float", "distance of the TCP from the plate edge", 0.06, "m", min=0.0),
        "foot_clearance": Param("float", "height of the element's foot above the ground", 0.04, "m", min=0.0),
        "speed": Param("float", "travel speed", 0.15, "m/s", min=0.001, device="arm_speed"),
        "margin": Param("float", "least gap between the carried element and anything it passes", 0.01, "m", min=0.0),
        "max_foot": Param("float", "highest the element's foot rises to pass over what lies on the table", 0.15,
                          "m", min=0.0),
    }
    READS = (keys.ELEMENT, keys.PLATES, keys.ELEMENT_LENGTH, keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING)
    OPTIONAL_READS = (keys.ELEMENT_LENGTH,)  # measured by vis_scan; else the design length

    def setup(self, **kwargs) -> None:
        super().setup(**kwargs)
        self.design = kwargs.get("design")  # the other elements, lying or standing, when there is one

    def program(self):
        element = self.read(keys.ELEMENT)
        plates = self.read(keys.PLATES, {})
        plate = plate_of(element, plates)
        length = self.read(keys.ELEMENT_LENGTH, element["size"][0])
        obstacles = [plate_box(pid, p) for pid, p in plates.items()]
        obstacles += other_elements(self.design, element["id"])
        half_width = max(element["size"][1], element["size"][2]) / 2.0
        start = self.pose()
        blocked = []
        for where, goal in approach_points(plate, self.p.at, self.p.side):
            try:
                path = transit_path(start[:3], goal, self.p.foot_clearance, length, half_width, obstacles,
                                    self.p.margin, self.p.max_foot)
                break
            except NoPath as exc:
                blocked.append(f"{where}: {exc}")
        else:
            return self.fail(f"element {element['id']}: no clear path to plate {element['plate']} ("
                             + "; ".join(blocked) + "); move the pick area or the plates, or lower 'margin'")
        self.feedback_message = f"to the {where} of {element['plate']} by {len(path)} waypoints"
        for waypoint in path:
            fault = yield from self.move(np.r_[waypoint, start[3:]], self.p.speed)
            if fault:
                return self.fail(fault)
        return Status.SUCCESS
