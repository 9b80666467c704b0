"""The 3-D cell for the viewer: plates and elements of the design as boxes, the tool pose as a
transform (rotation vectors turned into quaternions, a whole column at once)."""

from __future__ import annotations

import numpy as np
import rerun as rr

from assembly.design.model import DesignModel

PLATE_THICKNESS = 0.01  # m, drawn only
PLATE_COLOUR = (120, 120, 140, 160)
ELEMENT_COLOURS = {"planned": (200, 200, 200, 90), "picking": (70, 130, 230, 255), "placing": (240, 170, 40, 255),
                   "placed": (60, 180, 75, 255), "failed": (220, 50, 47, 255)}


def quaternions(rotvecs: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions [x, y, z, w] of (N, 3) rotation vectors."""
    angle = np.linalg.norm(rotvecs, axis=1, keepdims=True)
    half = angle / 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        axis = np.where(angle > 1e-12, rotvecs / angle, 0.0)
    return np.hstack([axis * np.sin(half), np.cos(half)])


def plate_boxes(design: DesignModel) -> rr.Boxes3D:
    """Each plate of the design as a thin box spanning +x from its left support."""
    plates = design.plates()
    centres, halves = [], []
    for plate in plates.values():
        origin = np.asarray(plate["origin"], float)
        centres.append(origin + [plate["span"] / 2.0, 0.0, PLATE_THICKNESS / 2.0])
        halves.append([plate["span"] / 2.0, plate.get("width", 0.3) / 2.0, PLATE_THICKNESS / 2.0])
    return rr.Boxes3D(centers=centres, half_sizes=halves, labels=list(plates), colors=[PLATE_COLOUR] * len(plates))


def element_box(element: dict, status: str) -> rr.Boxes3D:
    """One element as a box at its as-built pose (or its pick pose while planned), coloured by status."""
    pose = np.asarray(element.get("asbuilt_pose") or element["pick_pose"], float)
    return rr.Boxes3D(centers=[pose[:3]], half_sizes=[np.asarray(element["size"], float) / 2.0],
                      quaternions=quaternions(pose[None, 3:6]), labels=[element["id"]],
                      colors=[ELEMENT_COLOURS.get(status, ELEMENT_COLOURS["planned"])])
