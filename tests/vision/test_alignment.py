"""Algorithm 1 (seed 002 §7.3.3): the Hough alignment recovers a known rotation."""

import math

import cv2
import numpy as np
import pytest

from visnav.vision.alignment import binary_edges, hough_alignment, hough_lines
from visnav.vision.geolocation_registration import sobel_edges
from visnav.world.rural import rural_map


@pytest.fixture(scope="module")
def patch():
    m = rural_map(200.0, 0.25, np.random.default_rng(5))
    return m.image[200:600, 200:600]


def _rotated_pair(img, deg):
    h, w = img.shape
    R = cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), deg, 1.0)
    rot = cv2.warpAffine(img, R, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    yy, xx = np.ogrid[:h, :w]
    disc = (yy - (h - 1) / 2) ** 2 + (xx - (w - 1) / 2) ** 2 <= (0.45 * min(h, w)) ** 2
    a = binary_edges(sobel_edges(img))
    b = binary_edges(sobel_edges(rot))
    a[~disc] = 0
    b[~disc] = 0
    return a, b


@pytest.mark.parametrize("deg", [-30.0, -12.5, 7.0, 25.0, 40.0])
def test_recovers_known_rotation(patch, deg):
    ref, sensed = _rotated_pair(patch, deg)  # sensed = reference content rotated by +deg on screen
    al = hough_alignment(sensed, ref)
    assert al.applied, al.reason
    # the content must be rotated back by -deg (counterclockwise positive) to match the reference
    assert math.degrees(al.angle) == pytest.approx(-deg, abs=1.0)
    assert al.pairs >= 2


def test_lines_of_a_synthetic_road():
    img = np.zeros((200, 200), np.uint8)
    cv2.line(img, (0, 40), (199, 140), 255, 1)  # slope 0.5: normal angle 90 + atan(0.5)
    th, votes = hough_lines(img, max_lines=3, min_votes_frac=0.3)
    assert th.size >= 1
    assert math.degrees(th[0]) == pytest.approx(90.0 + math.degrees(math.atan(0.5)), abs=0.5)
    assert votes[0] > 150


def test_not_applied_without_lines_or_beyond_45_deg(patch):
    empty = np.zeros((100, 100), np.uint8)
    assert not hough_alignment(empty, empty).applied
    ref, sensed = _rotated_pair(patch, 60.0)
    al = hough_alignment(sensed, ref)
    # 60 deg is outside the +-45 deg the algorithm assumes: it must not report a 60 deg rotation
    assert not (al.applied and abs(abs(math.degrees(al.angle)) - 60.0) < 5.0)
