"""visnav.scalar: the single-number helpers give numpy's results."""

import math

import numpy as np

from visnav.scalar import clip


def test_clip_equals_numpy_clip_on_single_numbers():
    rng = np.random.default_rng(0)
    xs = list(rng.normal(0.0, 2.0, 500)) + [math.nan, math.inf, -math.inf, -0.0, 0.0, 1.0, -1.0]
    for lo, hi in ((-1.0, 1.0), (0.0, 0.5), (-2.5, -0.5)):
        for x in xs:
            want = float(np.clip(x, lo, hi))
            got = clip(x, lo, hi)
            assert type(got) is float
            assert (math.isnan(want) and math.isnan(got)) or (got == want and math.copysign(1, got) == math.copysign(1, want))
    assert clip(np.float64(3.0), 0, 1) == 1.0 and type(clip(np.float64(3.0), 0, 1)) is float
