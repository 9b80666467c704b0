"""Carry the held, upright element to beside the plate it must prop, at the start of the
span to search, with its foot a set height above the ground."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours import keys
from behaviours.base import Param, ProgramSkill
from behaviours.registry import register


def plate_of(element: dict, plates: dict) -> dict:
    """The design plate an element props; KeyError naming both when it is missing."""
    try:
        return plates[element["plate"]]
    except KeyError:
        raise KeyError(f"element {element.get('id')!r} names plate {element.get('plate')!r}, "
                       f"which the design model does not have") from None


@register
class ApproachPlate(ProgramSkill):
    NAME = "approach_plate"
    SUMMARY = "bring the upright element beside its plate at the start of the search span"
    PARAMS = {
        "at": Param("float", "position along the span where the search starts", 0.1, "fraction of span", min=0.0, max=1.0),
        "side": Param("float", "distance of the TCP from the plate edge", 0.06, "m", min=0.0),
        "foot_clearance": Param("float", "height of the element's foot above the ground", 0.04, "m", min=0.0),
        "speed": Param("float", "travel speed", 0.15, "m/s", min=0.001),
    }
    READS = (keys.ELEMENT, keys.PLATES, keys.ELEMENT_LENGTH, keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING)
    OPTIONAL_READS = (keys.ELEMENT_LENGTH,)  # measured by vis_scan; else the design length

    def program(self):
        element = self.read(keys.ELEMENT)
        plate = plate_of(element, self.read(keys.PLATES, {}))
        length = self.read(keys.ELEMENT_LENGTH, element["size"][0])
        origin = np.asarray(plate["origin"], float)
        target = self.pose()
        target[0] = origin[0] + self.p.at * plate["span"]
        target[1] = origin[1] - plate["width"] / 2.0 - self.p.side
        target[2] = length / 2.0 + self.p.foot_clearance
        fault = yield from self.move(target, self.p.speed)
        if fault:
            return self.fail(fault)
        return Status.SUCCESS
