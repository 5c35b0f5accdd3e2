"""Orbit outer loop (seed 004 eq. 5.1-5.4, 7.1, Table 7.1) and the radius filter."""

import math

import pytest

from visnav.guidance.orbit import OrbitGains, OrbitGuidance
from visnav.navigation.condor import RadiusFilter

G0, G1 = OrbitGains(0.001, 0.01), OrbitGains(0.015, 0.05)


def test_original_base_is_current_circle_limited_40pct():
    g = OrbitGuidance("original", 110.0, 17.0, G0, G1)
    nominal = 17.0 / 110.0
    assert g.update(0.02, 120.0, 0.0, 17.0)["base"] == pytest.approx(17.0 / 120.0)  # eq. 5.2
    assert g.update(0.02, 30.0, 0.0, 17.0)["base"] == pytest.approx(1.4 * nominal)  # limited +40 %
    assert g.update(0.02, 900.0, 0.0, 17.0)["base"] == pytest.approx(0.6 * nominal)
    r = g.update(0.02, 120.0, 0.5, 17.0)
    assert r["err"] == pytest.approx(0.001 * 10 + 0.01 * 0.5)  # eq. 5.1: outside and moving out -> turn in
    assert r["psidot_ref_rud"] == pytest.approx(r["psidot_ref_ail"])


def test_modified_base_is_constant_and_rudder_keeps_original():
    g = OrbitGuidance("modified", 110.0, 17.0, G0, G1)
    a = g.update(0.02, 100.0, 0.0, 17.0)
    b = g.update(0.02, 130.0, 0.0, 17.0)
    assert a["base"] == pytest.approx(17.0 / 110.0) and b["base"] == pytest.approx(17.0 / 110.0)  # eq. 7.1
    assert b["err"] == pytest.approx(0.015 * 20)
    assert b["psidot_ref_rud"] == pytest.approx(17.0 / 130.0 + 0.001 * 20)  # Table 7.1: rudder unchanged
    c = OrbitGuidance("coordinated", 110.0, 17.0, G0, G1).update(0.02, 100.0, 0.0, 17.0)
    assert c["psidot_ref_rud"] is None
    # the average ground speed estimate follows the airspeed slowly
    for _ in range(3000 * 5):
        g.update(0.02, 110.0, 0.0, 16.0)
    assert g.v_avg == pytest.approx(16.0, abs=0.01)


def test_bad_logic():
    with pytest.raises(ValueError, match="orbit logic"):
        OrbitGuidance("fancy", 110.0, 17.0, G0, G1)


def test_radius_filter_ramp_dropouts_and_stale():
    f = RadiusFilter()
    assert f.stale(0.0) and math.isnan(f.predict(0.0)[0])
    for k in range(200):
        t = k / 7.5
        if k % 7 == 3:
            continue  # dropouts
        f.update(t, 100.0 + 2.0 * t)
    t = 199 / 7.5
    R, Rdot = f.predict(t + 0.5)
    assert Rdot == pytest.approx(2.0, rel=1e-3) and R == pytest.approx(100 + 2 * (t + 0.5), abs=0.05)
    f.update(t + 1, math.nan)  # "no estimate" is ignored
    assert f.stale(t + 3.5) and not f.stale(t + 2.0)
