"""An outside observer of the vehicle over the deck: the thesis' motion capture (Vicon) and safety pilot.

Seed 003 §5.3.5 started the moving-deck filter from the Vicon pose, and in every flight a safety
pilot flew the vehicle by hand until the hand-over (§5.3.1). Both see the vehicle relative to the
deck; here they are one sensor that returns the 12 relative states of ``estimation/deck.py`` plus
white noise of ``sigma`` per state (``RelativeStateSample``). The simulation uses it for the Vicon
start (``filter.init = "truth"``: the ``NavInit`` it sends and logs) and the deck mission reads it in
``manual`` mode when ``start.pilot = "truth"`` (the pilot holds the start point on what he sees).
"""

from __future__ import annotations

import numpy as np

from visnav.estimation.deck import wrap_state
from visnav.measurements import RelativeStateSample
from visnav.sensors.base import TruthAt


class RelativeStateSensor:
    def __init__(self, rng: np.random.Generator | None, sigma, rate_hz: float, latency_s: float = 0.0,
                 source: str = "pilot"):
        self.rng, self.rate_hz, self.latency_s, self.source = rng, rate_hz, latency_s, source
        self.sigma = np.broadcast_to(np.asarray(sigma, float), (12,)).copy()
        if np.any(self.sigma > 0) and rng is None:
            raise ValueError("a noisy relative-state sensor needs a random generator")

    def sample(self, t: float, truth_at: TruthAt, world) -> RelativeStateSample:
        x = world.relative(truth_at(t), world.motion.state(t))
        if (self.sigma > 0).any():
            x = wrap_state(x + self.sigma * self.rng.standard_normal(12))
        return RelativeStateSample(t=t, state=x, sigma=self.sigma.copy(), source=self.source)
