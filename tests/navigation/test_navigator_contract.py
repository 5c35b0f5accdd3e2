"""Every registered navigator honours the one protocol of ``navigation/base`` (issue #31 item 5)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from visnav.app.navigators import NAVIGATORS, make_navigator
from visnav.measurements import Health, NavCommand, NavInit
from visnav.navigation.base import Navigator
from visnav.scenarios.schema import load_scenario
from visnav.sensors.pantilt import PanTiltUnit


@pytest.mark.parametrize("name", sorted(NAVIGATORS))
def test_every_registered_navigator_offers_the_protocol(name):
    spec = NAVIGATORS[name]
    parts = {"ptu": PanTiltUnit(pan=0.0, tilt=-1.0)} if name == "pad" else {}  # the pad camera's own pan-tilt unit
    try:
        nav = make_navigator(name, load_scenario(spec.scenario), **parts)
    except TypeError as e:  # a builder that needs a part of its run (the map) names it
        pytest.fail(f"{name}: cannot be built from its scenario alone: {e}")
    assert isinstance(nav, Navigator), f"{name}: {type(nav).__name__} lacks a method of the protocol"
    with pytest.raises(ValueError, match="no command"):
        nav.command(NavCommand(0.0, "no-such-command"))
    nav.initialize(NavInit(0.0, "operator", position=np.zeros(3), velocity=np.zeros(3), attitude=np.zeros(3)))
    e = nav.estimate(0.0)
    assert e.t == 0.0 and isinstance(e.valid, bool)
    pos = np.asarray(e.position, float)
    cov = np.asarray(e.covariance, float)
    assert pos.ndim == 1 and pos.size in (2, 3)
    assert cov.shape[0] == cov.shape[1] >= pos.size  # a covariance per estimated coordinate at least
    if e.valid:  # what is valid is a number with a covariance
        assert np.all(np.isfinite(pos)) and math.isfinite(float(np.trace(cov[:pos.size, :pos.size])))
    assert isinstance(nav.health(0.0), Health)
