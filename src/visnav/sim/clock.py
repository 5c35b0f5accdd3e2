"""The simulation clock: one fixed dynamics step, every block at an integer divisor of it."""

from __future__ import annotations


def rate_divisor(rate_hz: float, dt: float) -> int:
    """Steps of ``dt`` between two runs of a block at ``rate_hz`` (at least 1): ``round(1 / (rate dt))``."""
    if not rate_hz > 0 or not dt > 0:
        raise ValueError(f"rate and step must be positive, got rate {rate_hz} Hz, step {dt} s")
    return max(1, int(round(1.0 / (rate_hz * dt))))
