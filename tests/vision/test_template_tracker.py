"""Rotating template tracker of the operator's click (seed 002 §7.4.3) on a pasted truck."""

import math

import cv2
import numpy as np

from visnav.vision.template_tracker import RotatingTemplateTracker
from visnav.world.rural import rural_map
from visnav.world.targets import paste_truck


def test_finds_the_truck_after_the_view_turned():
    geo = paste_truck(rural_map(120.0, 0.25, np.random.default_rng(2)), [3.0, -4.0], 7.0, 2.5, 0.4)
    img = cv2.resize(geo.image, None, fx=2, fy=2, interpolation=cv2.INTER_LINEAR)  # 0.125 m/px "frame"
    (c, r), = geo.ned_to_pixel(np.array([[3.0, -4.0]]))
    uv = np.array([2 * c + 0.5, 2 * r + 0.5])
    tr = RotatingTemplateTracker()
    tr.start(img, uv, heading=0.0)
    h, w = img.shape
    for turn_deg in (0.0, 25.0, -60.0):
        R = cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), turn_deg, 1.0)  # view turned with the heading
        rot = cv2.warpAffine(img, R, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
        expect = R @ np.array([uv[0], uv[1], 1.0])
        res = tr.track(rot, heading=math.radians(turn_deg + 8.0))  # heading 8 deg off
        assert res.ok, (turn_deg, res.score)
        assert np.linalg.norm(res.uv - expect) < 3.0, (turn_deg, res.uv, expect)


def test_reports_not_found_where_the_truck_is_not_in_view():
    base = rural_map(120.0, 0.25, np.random.default_rng(2))
    geo = paste_truck(base, [3.0, -4.0], 7.0, 2.5, 0.4)
    (c, r), = geo.ned_to_pixel(np.array([[3.0, -4.0]]))
    k = 2.5  # frames at 0.1 m/px, as at 70 m with the 53 deg camera on 720 px
    rng = np.random.default_rng(5)
    up = [cv2.add(cv2.resize(g.image, None, fx=k, fy=k, interpolation=cv2.INTER_LINEAR),
                  rng.normal(0, 4.0, (1200, 1200)).round().astype(np.int16), dtype=cv2.CV_8U) for g in (geo, base)]
    tr = RotatingTemplateTracker()
    tr.start(up[0], [k * c + (k - 1) / 2, k * r + (k - 1) / 2], 0.0)
    true = tr.track(up[0], 0.0)
    assert true.ok
    # views of the ground elsewhere (the truck and its surroundings out of view, camera noise on)
    for view in (up[1][:, 700:], up[1][:500], up[1][700:]):
        tr.last = None
        other = tr.track(view, 0.0)
        assert not other.ok or other.score < true.score - 0.1
