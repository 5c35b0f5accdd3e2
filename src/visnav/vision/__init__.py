"""visnav.vision: image algorithms (seed 000 §2.2: Förstner interest operator, Moravec PNCC tracker;
seed 002 ch. 5 / app. B: KLT, DLT + RANSAC homography, visual odometry, map registration)."""

from __future__ import annotations

from visnav.vision.correlation import PnccTracker, TrackResult, pncc
from visnav.vision.homography import normalized_dlt, ransac_homography
from visnav.vision.klt import KltTracker
from visnav.vision.odometry import VisualOdometry, displacement_from_homography
from visnav.vision.registration import MapRegistration
from visnav.vision.interest import InterestPoint, forstner, forstner_response, forstner_top_k

__all__ = [
    "InterestPoint",
    "KltTracker",
    "MapRegistration",
    "VisualOdometry",
    "displacement_from_homography",
    "normalized_dlt",
    "ransac_homography",
    "PnccTracker",
    "TrackResult",
    "forstner",
    "forstner_response",
    "forstner_top_k",
    "pncc",
]
