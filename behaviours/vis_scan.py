"""VisScan: follow the element along its axis with proximity vision until each end leaves the
fingertip view; the two edges give the element's length and its middle (the grasp point)."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill, magnitude
from behaviours.skill_kit.geometry import rotation
from behaviours.skill_kit.registry import register


@register
class VisScan(ProgramSkill):
    NAME = "vis_scan"
    SUMMARY = "measure the element's length by finding both ends with proximity vision"
    PARAMS = {
        "step": Param("float", "scan distance per tick (sets the scan speed)", 0.002, "m", min=1e-4, max=0.02),
        "edge_fraction": Param("float", "share of the full-view area at which the edge is declared", 0.5, min=0.05, max=0.95),
        "max_travel": Param("float", "longest scan in each direction", 0.5, "m", min=0.01, max=1.0),
        "length_tolerance": Param("float", "allowed difference from the design length", 0.02, "m", min=0.0),
        "speed": Param("float", "speed of the final move to the middle", 0.1, "m/s", min=0.001, device="arm_speed"),
        "reference_ticks": Param("int", "ticks the full-view area is averaged over (the seen area is noisy)", 5,
                                 min=1),
    }
    READS = (keys.ELEMENT, keys.FV_LEFT, keys.FV_RIGHT, keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING)
    WRITES = (keys.ELEMENT_LENGTH, keys.ELEMENT_POSE)

    def _area(self) -> float:
        left, right = self.tactile()
        return left.obj.area + right.obj.area

    def _find_edge(self, direction: np.ndarray, threshold: float):
        """Move along `direction` at one `step` per tick until the seen area drops below
        `threshold`; return the interpolated TCP position of the crossing, or None.

        A speed command, not a move per tick: a real controller starts every move from rest, so
        a move of one step per tick would crawl at a fraction of the scan speed."""
        arm = self.cell.arm
        start = self.pose()[:3]
        prev_pos, prev_area = start.copy(), self._area()
        arm.speed_linear(np.r_[direction * (self.p.step / self.cell.clock.period), 0.0, 0.0, 0.0])
        pos = start
        while magnitude(pos - start) < self.p.max_travel:
            yield
            if self.arm_fault():
                return None
            pos, area = self.pose()[:3], self._area()
            if area < threshold <= prev_area:
                w = (prev_area - threshold) / max(prev_area - area, 1e-12)
                arm.stop()
                return prev_pos + w * (pos - prev_pos)
            prev_pos, prev_area = pos.copy(), area
        arm.stop()
        return None

    def program(self):
        element = self.read(keys.ELEMENT)
        areas = [self._area()]
        for _ in range(self.p.reference_ticks - 1):
            yield
            areas.append(self._area())
        full = float(np.mean(areas))
        if min(areas) <= 0.0:
            return self.fail("no object in view: locate the element first")
        threshold = self.p.edge_fraction * full
        axis = rotation(self.pose())[:, 0]
        edges = []
        for sign in (1.0, -1.0):
            self.feedback_message = f"scanning {'forward' if sign > 0 else 'back'}"
            edge = yield from self._find_edge(sign * axis, threshold)
            fault = self.arm_fault()
            if fault:
                return self.fail(f"arm fault: {fault}")
            if edge is None:
                return self.fail(f"no element end within {self.p.max_travel} m scanning "
                                 f"{'forward' if sign > 0 else 'back'}")
            edges.append(edge)
        length = float(np.linalg.norm(edges[0] - edges[1]))
        design = element["size"][0] if element else None
        if design is not None and abs(length - design) > self.p.length_tolerance:
            return self.fail(f"measured length {length:.4f} m differs from the design "
                             f"{design:.4f} m by more than {self.p.length_tolerance} m")
        middle = self.pose()
        middle[:3] = (edges[0] + edges[1]) / 2.0
        fault = yield from self.move(middle, self.p.speed)
        if fault:
            return self.fail(fault)
        self.write(keys.ELEMENT_LENGTH, length)
        self.write(keys.ELEMENT_POSE, middle)
        self.feedback_message = f"length {length:.4f} m"
        return Status.SUCCESS
