"""visnav.vision: image algorithms (seed 000 §2.2: Förstner interest operator, Moravec PNCC tracker)."""

from __future__ import annotations

from visnav.vision.correlation import PnccTracker, TrackResult, pncc
from visnav.vision.interest import InterestPoint, forstner, forstner_response, forstner_top_k

__all__ = [
    "InterestPoint",
    "PnccTracker",
    "TrackResult",
    "forstner",
    "forstner_response",
    "forstner_top_k",
    "pncc",
]
