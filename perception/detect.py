"""Marker detection: threshold the black markers, then find blobs with the original's
SimpleBlobDetector or with connected components and sub-pixel, darkness-weighted centroids.

Both detectors work on the whole frame or on a region (the ROI search of the original tracker).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from perception.config import DetectorConfig, ThresholdConfig

_KERNEL = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class Blobs:
    """Detected blobs: centre (M, 2) in px and diameter (M,) in px."""

    xy: np.ndarray
    size: np.ndarray

    def __len__(self) -> int:
        return len(self.size)

    @staticmethod
    def empty() -> Blobs:
        return Blobs(np.zeros((0, 2)), np.zeros(0))


@dataclass(frozen=True)
class Prepared:
    """One frame made ready for detection: marker mask (255 = marker) and darkness weights."""

    mask: np.ndarray  # uint8, 255 where a pixel is dark enough to be a marker
    weight: np.ndarray  # float32, how far below the threshold a pixel is (0 outside the mask)


def marker_mask(bgr: np.ndarray, grey: np.ndarray, cfg: ThresholdConfig) -> Prepared:
    """Threshold the markers: fixed V (= max of B, G, R) as the original, or below the local mean."""
    if cfg.mode == "hsv":
        # V <= v_max over the full H and S range is exactly max(B, G, R) <= v_max.
        v = cv2.max(cv2.max(bgr[:, :, 0], bgr[:, :, 1]), bgr[:, :, 2])
        level = np.float32(cfg.v_max + 1)
        weight = level - v.astype(np.float32)
    else:
        local = cv2.blur(grey, (cfg.block, cfg.block), borderType=cv2.BORDER_REPLICATE)
        weight = local.astype(np.float32) - np.float32(cfg.offset) - grey.astype(np.float32)
    mask = (weight > 0).view(np.uint8) * np.uint8(255)
    if cfg.n_dilate:
        mask = cv2.dilate(mask, _KERNEL, iterations=cfg.n_dilate)
    if cfg.n_erode:
        mask = cv2.erode(mask, _KERNEL, iterations=cfg.n_erode)
    np.maximum(weight, 0.0, out=weight)
    weight[mask == 0] = 0.0
    return Prepared(mask, weight)


class ComponentDetector:
    """Connected components of the marker mask, filtered by area and shape, with weighted centroids."""

    def __init__(self, cfg: DetectorConfig):
        self.cfg = cfg

    def detect(self, prep: Prepared, roi: tuple[int, int, int, int] | None = None) -> Blobs:
        """Blobs in the frame or in roi = (x0, y0, x1, y1), in full-frame coordinates."""
        x0, y0, x1, y1 = roi if roi is not None else (0, 0, prep.mask.shape[1], prep.mask.shape[0])
        mask = prep.mask[y0:y1, x0:x1]
        weight = prep.weight[y0:y1, x0:x1]
        blobs, rejected = self._components(mask, weight)
        if self.cfg.split and rejected is not None and len(blobs):
            # A marker merged with a dark edge or a neighbour: opening the rejected components with a
            # disc a little smaller than a marker removes the thinner parts and frees the marker.
            d = max(3, int(0.75 * float(np.median(blobs.size))) | 1)
            opened = cv2.morphologyEx(rejected, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (d, d)))
            freed, _ = self._components(opened, weight)
            blobs = Blobs(np.concatenate([blobs.xy, freed.xy]), np.concatenate([blobs.size, freed.size]))
        return Blobs(blobs.xy + (x0, y0), blobs.size)

    def _components(self, mask: np.ndarray, weight: np.ndarray) -> tuple[Blobs, np.ndarray | None]:
        """Marker-like components of `mask` (region coordinates), and a mask of the rejected ones."""
        n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8, ltype=cv2.CV_32S)
        if n <= 1:
            return Blobs.empty(), None
        area = stats[:, cv2.CC_STAT_AREA].astype(float)
        bw, bh = stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT]
        fill = area / np.maximum(bw * bh, 1)
        aspect = np.maximum(bw, bh) / np.maximum(np.minimum(bw, bh), 1)
        keep = (area >= self.cfg.min_area) & (area <= self.cfg.max_area) & (fill >= 0.45) & (aspect <= 2.5)
        keep[0] = False  # label 0 is the background
        rejected = None
        if self.cfg.split:
            big = ~keep & (area > self.cfg.min_area)
            big[0] = False
            rejected = (big[labels]).view(np.uint8) * np.uint8(255) if big.any() else None
        if not keep.any():
            return Blobs.empty(), rejected
        ys, xs = np.nonzero(mask)
        lab = labels[ys, xs]
        w = weight[ys, xs].astype(float) + 1e-3  # never an all-zero blob
        sw = np.bincount(lab, w, minlength=n)
        sw[0] = 1.0  # the background label has no mask pixels
        cx = np.bincount(lab, w * xs, minlength=n) / sw
        cy = np.bincount(lab, w * ys, minlength=n) / sw
        xy = np.column_stack([cx[keep], cy[keep]])
        return Blobs(xy, 2.0 * np.sqrt(area[keep] / np.pi)), rejected


class BlobDetector:
    """OpenCV SimpleBlobDetector on the thresholded mask, with the original FingerVision defaults."""

    def __init__(self, cfg: DetectorConfig):
        p = cv2.SimpleBlobDetector_Params()
        p.minThreshold, p.maxThreshold, p.thresholdStep = cfg.blob_thresholds
        p.filterByArea, p.minArea, p.maxArea = True, cfg.min_area, cfg.max_area
        p.filterByCircularity, p.minCircularity = True, cfg.min_circularity
        p.filterByConvexity, p.minConvexity = True, cfg.min_convexity
        p.filterByInertia, p.minInertiaRatio = True, cfg.min_inertia_ratio
        p.minDistBetweenBlobs = cfg.min_dist_between
        p.minRepeatability = cfg.min_repeatability
        # The mask has white markers: a colour filter for black blobs would drop most of them.
        p.filterByColor = False
        self._detector = cv2.SimpleBlobDetector.create(p)

    def detect(self, prep: Prepared, roi: tuple[int, int, int, int] | None = None) -> Blobs:
        """Blobs in the frame or in roi = (x0, y0, x1, y1), in full-frame coordinates."""
        x0, y0, x1, y1 = roi if roi is not None else (0, 0, prep.mask.shape[1], prep.mask.shape[0])
        keypoints = self._detector.detect(prep.mask[y0:y1, x0:x1])
        if not keypoints:
            return Blobs.empty()
        xy = np.array([k.pt for k in keypoints], float) + (x0, y0)
        return Blobs(xy, np.array([k.size for k in keypoints], float))


Detector = ComponentDetector | BlobDetector


def make_detector(cfg: DetectorConfig) -> Detector:
    """The detector named by `cfg.kind`."""
    if cfg.kind == "blob":
        return BlobDetector(cfg)
    return ComponentDetector(cfg)
