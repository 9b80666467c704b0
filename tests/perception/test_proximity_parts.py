"""The quick forms of proximity vision's per-frame parts give what the plain formulas give: 3x3 cell
means, the H x S x V bin of each pixel, the object mask of the current model and its moments, and
slip's sparse sample of the frame."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from perception.config import HealthConfig, ProximityConfig
from perception.frames import ImageQuality
from perception.proximity import ProximityVision, cell_means
from perception.slip import every_nth

RANGES = (180, 256, 256)


def _random_mask(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """A 0/255 mask of a few filled ellipses."""
    mask = np.zeros(shape, np.uint8)
    h, w = shape
    for _ in range(3):
        centre = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        axes = (int(rng.integers(3, w // 2)), int(rng.integers(3, h // 2)))
        cv2.ellipse(mask, centre, axes, float(rng.uniform(0, 180)), 0, 360, 255, -1)
    return mask


@pytest.mark.parametrize("shape", [(120, 160), (121, 160), (120, 163), (7, 11)])
def test_cell_means_are_the_block_means_of_the_cropped_mask(shape):
    rng = np.random.default_rng(shape[0] * 1000 + shape[1])
    mask = rng.choice(np.array([0, 127, 255], np.uint8), size=shape)
    h, w = shape
    ch, cw = h // 3, w // 3
    expected = [[mask[i * ch:(i + 1) * ch, j * cw:(j + 1) * cw].mean() for j in range(3)] for i in range(3)]
    np.testing.assert_allclose(cell_means(mask), expected, rtol=0, atol=1e-12)


def test_bins_are_the_row_major_hsv_histogram_bins_of_the_resized_frame():
    cfg = ProximityConfig()
    prox = ProximityVision(cfg)
    rng = np.random.default_rng(1)
    bgr = rng.integers(0, 256, (240, 320, 3), dtype=np.uint8)
    frame = prox.prepare(bgr)
    hsv = cv2.cvtColor(cv2.resize(bgr, (cfg.width, cfg.height), interpolation=cv2.INTER_NEAREST),
                       cv2.COLOR_BGR2HSV).astype(int)
    index = [np.minimum(hsv[:, :, c] * n // r, n - 1) for c, (n, r) in enumerate(zip(cfg.bins, RANGES))]
    expected = (index[0] * cfg.bins[1] + index[1]) * cfg.bins[2] + index[2]
    np.testing.assert_array_equal(frame.bins, expected)
    np.testing.assert_array_equal(frame.not_black > 0, hsv[:, :, 2] > cfg.thresh_blk_v)


def test_area_centroid_and_orientation_are_those_of_the_binary_mask():
    prox = ProximityVision(ProximityConfig())
    rng = np.random.default_rng(2)
    for _ in range(20):
        mask = _random_mask(rng, (120, 160))
        info = prox.describe(mask)
        m = cv2.moments(mask, binaryImage=True)
        assert info.area == pytest.approx(m["m00"] / mask.size, rel=1e-12)
        if not info.present:
            continue
        div = (160 + 120) / 2.0
        centroid = [(m["m10"] / m["m00"] - 80.0) / div, (m["m01"] / m["m00"] - 60.0) / div]
        np.testing.assert_allclose(info.centroid, centroid, rtol=1e-12, atol=1e-12)
        angle = 0.5 * np.arctan2(2.0 * m["mu11"], m["mu20"] - m["mu02"])
        assert info.orientation == pytest.approx(angle, abs=1e-9)


def test_the_object_mask_follows_every_change_of_the_colour_model():
    """The back-projection table is kept between frames: it must be made again after a hand edit."""
    prox = ProximityVision(ProximityConfig())
    image = np.full((240, 320, 3), (200, 200, 200), np.uint8)
    cv2.rectangle(image, (100, 80), (220, 160), (40, 120, 235), -1)  # an orange object
    frame = prox.prepare(image)
    assert not prox.object_masks(frame)[0].any()  # no model yet
    mask = np.zeros((240, 320), np.uint8)
    mask[80:161, 100:221] = 1
    prox.add_object(image, mask)
    obj, wide = prox.object_masks(frame)
    assert prox.describe(obj).present and np.count_nonzero(wide) > np.count_nonzero(obj)
    prox.add_object(np.full((240, 320, 3), (200, 200, 200), np.uint8), np.ones((240, 320), np.uint8))
    obj_grey = prox.object_masks(frame)[0]  # the grey background joins the model
    assert np.count_nonzero(obj_grey) > 2 * np.count_nonzero(obj)


def test_image_quality_reports_the_saturated_share_of_the_frame_it_checked():
    quality = ImageQuality(HealthConfig(saturated_share=1.0))
    grey = np.full((240, 320), 120, np.uint8)
    grey[:, :80] = 255  # a quarter of the frame
    assert quality.problem(grey) == ""
    assert quality.saturated == pytest.approx(0.25)
    assert quality.problem(np.full((240, 320), 120, np.uint8)) == ""
    assert quality.saturated == 0.0


@pytest.mark.parametrize(("shape", "step"), [((120, 160), 2), ((120, 160), 4), ((121, 161), 2), ((120, 160), 3)])
def test_every_nth_is_the_strided_slice(shape: tuple[int, int], step: int) -> None:
    """Slip's sample of every step-th pixel is `bgr[::step, ::step]`, whether or not step divides the sides."""
    bgr = np.random.default_rng(7).integers(0, 256, (*shape, 3), dtype=np.uint8)
    sample = every_nth(bgr, step)
    assert sample.flags.c_contiguous
    np.testing.assert_array_equal(sample, bgr[::step, ::step])
