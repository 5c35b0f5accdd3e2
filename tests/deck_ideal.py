"""Deck scenarios with the ideal sensors: no calibration, survey, time-offset or IMU-bias errors (issue 30 item 3).

Tests that pin one seed's flight (modes, touchdown figures, restarts) were written for the ideal case; the realistic
errors are measured by the campaigns (docs/results-deck.md) and checked in tests/sim/test_deck_realism.py."""

from visnav.scenarios.config_deck import IDEAL_DECK_SENSORS
from visnav.scenarios.schema import load_scenario


def load_ideal_deck(name: str, overrides: list[str] | None = None, seed: int | None = None):
    """``load_scenario`` of a deck scenario with ``IDEAL_DECK_SENSORS`` before ``overrides``."""
    return load_scenario(name, [*IDEAL_DECK_SENSORS, *(overrides or [])], seed=seed)
