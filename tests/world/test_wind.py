"""Steady wind and Dryden turbulence (MIL-HDBK-1797 low-altitude model)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from visnav.world.wind import DrydenTurbulence, SteadyWind, Wind, to_ned

FT, KT = 0.3048, 1852.0 / 3600.0


def _psd_u(w, s, length, v):
    return s**2 * 2 * length / (math.pi * v) / (1 + (length * w / v) ** 2)


def _psd_vw(w, s, length, v):
    x = (length * w / v) ** 2
    return s**2 * length / (math.pi * v) * (1 + 3 * x) / (1 + x) ** 2


def test_steady_wind_meteorological_convention() -> None:
    np.testing.assert_allclose(SteadyWind(7.0, 90.0).ned, [0.0, -7.0, 0.0], atol=1e-12)  # east wind
    np.testing.assert_allclose(SteadyWind(5.0, 0.0).ned, [-5.0, 0.0, 0.0], atol=1e-12)
    sw = SteadyWind(2.0, 225.0).ned  # from south-west: towards north-east
    np.testing.assert_allclose(sw, [math.sqrt(2), math.sqrt(2), 0.0], atol=1e-12)
    with pytest.raises(ValueError, match="speed_mps"):
        SteadyWind(-1.0, 0.0)


def test_to_ned_axes_right_handed() -> None:
    u, v, w = to_ned(np.eye(3), 90.0)
    np.testing.assert_allclose(u, [0, -1, 0], atol=1e-12)  # downwind of an east wind: west
    np.testing.assert_allclose(v, [1, 0, 0], atol=1e-12)  # right of west, seen from above: north
    np.testing.assert_allclose(w, [0, 0, 1], atol=1e-12)
    for frm in (0.0, 33.0, 200.0):
        r = to_ned(np.eye(3), frm)
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(np.cross(r[0], r[1]), r[2], atol=1e-12)
        np.testing.assert_allclose(r[0], SteadyWind(1.0, frm).ned, atol=1e-12)


def test_parameters_low_altitude_model() -> None:
    d = DrydenTurbulence("moderate", np.random.default_rng(0), altitude_m=20 * FT, airspeed_mps=8.0)
    p = d.parameters()
    h = 20.0
    assert p["sigma_w"] == pytest.approx(0.1 * 30 * KT)  # sigma_w = 0.1 W20
    assert p["sigma_u"] / p["sigma_w"] == pytest.approx((0.177 + 0.000823 * h) ** -0.4)
    assert p["sigma_u"] / p["sigma_w"] == pytest.approx(1.928, abs=2e-3)
    assert p["L_w"] == pytest.approx(h * FT)
    assert p["L_u"] == pytest.approx(h / (0.177 + 0.000823 * h) ** 1.2 * FT)
    assert p["L_v"] == p["L_u"] and p["sigma_v"] == p["sigma_u"]
    light = DrydenTurbulence("light", np.random.default_rng(0)).parameters()
    severe = DrydenTurbulence("severe", np.random.default_rng(0)).parameters()
    assert (light["sigma_w"], severe["sigma_w"]) == pytest.approx((1.5 * KT, 4.5 * KT))
    # clamps: h >= 3 ft, V >= 1 m/s
    c = DrydenTurbulence(1.0, np.random.default_rng(0), altitude_m=0.1, airspeed_mps=0.0).parameters()
    assert (c["L_w"], c["V"], c["sigma_w"]) == pytest.approx((3 * FT, 1.0, 1.0))


def test_psd_matches_dryden_spectra_and_variance() -> None:
    d = DrydenTurbulence("moderate", np.random.default_rng(42), altitude_m=10.0, airspeed_mps=15.0)
    p = d.parameters()
    dt, n = 0.02, 2**19
    y = d.generate(n, dt)
    sig = np.array([p["sigma_u"], p["sigma_v"], p["sigma_w"]])
    np.testing.assert_allclose(y.var(axis=0), sig**2, rtol=0.10)
    assert np.all(np.abs(y.mean(axis=0)) < 0.1 * sig)
    f, pf = signal.welch(y, fs=1 / dt, nperseg=2**14, axis=0)
    phi = pf / (2 * math.pi)  # one-sided per Hz -> one-sided per rad/s
    w = 2 * math.pi * f
    an = np.stack(
        [
            _psd_u(w, p["sigma_u"], p["L_u"], p["V"]),
            _psd_vw(w, p["sigma_v"], p["L_v"], p["V"]),
            _psd_vw(w, p["sigma_w"], p["L_w"], p["V"]),
        ],
        axis=1,
    )
    # log-spaced bands from the 4th Welch bin to a fifth of Nyquist (no aliasing there)
    edges = np.geomspace(f[4], 0.1 / dt, 9)
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (f >= lo) & (f < hi)
        ratio = phi[m].mean(axis=0) / an[m].mean(axis=0)
        np.testing.assert_allclose(ratio, 1.0, rtol=0.15, err_msg=f"band {lo:.3f}-{hi:.3f} Hz")


def test_step_autocorrelation_matches_closed_form() -> None:
    """Sampled step() output has the Dryden correlations: u exp(-x/L); v, w (1 - x/2L) exp(-x/L)."""
    d = DrydenTurbulence("severe", np.random.default_rng(7), altitude_m=10.0, airspeed_mps=30.0)
    p = d.parameters()
    dt = 0.05
    s = np.array([d.step(dt) for _ in range(20000)])
    for k, tol in ((1, 0.02), (4, 0.06), (10, 0.06)):
        xi = p["V"] * k * dt
        expected = [
            math.exp(-xi / p["L_u"]),
            (1 - xi / (2 * p["L_v"])) * math.exp(-xi / p["L_v"]),
            (1 - xi / (2 * p["L_w"])) * math.exp(-xi / p["L_w"]),
        ]
        rho = (s[:-k] * s[k:]).mean(axis=0) / (s**2).mean(axis=0)
        np.testing.assert_allclose(rho, expected, atol=tol, err_msg=f"lag {k}")


def test_changing_altitude_keeps_the_process_stationary() -> None:
    d = DrydenTurbulence(1.0, np.random.default_rng(3), altitude_m=5.0, airspeed_mps=100.0)
    out: dict[float, list] = {5.0: [], 60.0: []}
    for seg in range(200):
        h = 5.0 if seg % 2 == 0 else 60.0
        out[h].extend(d.step(0.1, altitude_m=h) for _ in range(50))
    for h, ys in out.items():
        p = DrydenTurbulence(1.0, np.random.default_rng(0), altitude_m=h, airspeed_mps=100.0).parameters()
        sig = np.array([p["sigma_u"], p["sigma_v"], p["sigma_w"]])
        np.testing.assert_allclose(np.var(ys, axis=0), sig**2, rtol=0.25, err_msg=f"h = {h}")


def test_none_intensity_and_validation() -> None:
    d = DrydenTurbulence("none", np.random.default_rng(0))
    assert np.all(d.generate(100, 0.1) == 0) and np.all(d.step(0.1) == 0)
    with pytest.raises(ValueError, match=r"intensity.*light.*'extreme'"):
        DrydenTurbulence("extreme", np.random.default_rng(0))
    with pytest.raises(ValueError, match="sigma_w"):
        DrydenTurbulence(-1.0, np.random.default_rng(0))
    with pytest.raises(ValueError, match="dt"):
        d.step(-0.1)
    with pytest.raises(ValueError, match="n must"):
        d.generate(0, 0.1)
    with pytest.raises(ValueError, match="rng"):
        DrydenTurbulence("light", 1)  # type: ignore[arg-type]


def test_wind_is_steady_plus_rotated_gust() -> None:
    steady = SteadyWind(6.0, 135.0)
    wind = Wind(steady, DrydenTurbulence("moderate", np.random.default_rng(9)))
    twin = DrydenTurbulence("moderate", np.random.default_rng(9))
    for k in range(5):
        v = wind.velocity_ned(0.1 * k, 0.1, altitude_m=12.0, airspeed_mps=4.0)
        g = twin.step(0.1, altitude_m=12.0, airspeed_mps=4.0)
        np.testing.assert_allclose(v, steady.ned + to_ned(g, 135.0), atol=1e-12)
    assert np.linalg.norm(wind.velocity_ned(1.0, 0.1) - steady.ned) > 0
    np.testing.assert_allclose(Wind(steady).velocity_ned(0.0, 0.1), steady.ned)


def test_closed_form_discretisation_matches_scipy_expm():
    """Both unit shaping filters have all poles at -1: the closed form e^(-h)(I + hN) used by
    discretize() must equal scipy's expm over the whole range of steps (1e-4 to 30 time constants)."""
    from scipy import linalg

    from visnav.world.wind import _UNIT_U, _UNIT_VW

    for f in (_UNIT_U, _UNIT_VW):
        assert f._nil is not None
        for h in (1e-4, 3e-3, 0.05, 0.7, 2.0, 30.0):
            ad, lq = f.discretize(h)
            ref = linalg.expm(f.a * h)
            np.testing.assert_allclose(ad, ref, rtol=1e-12, atol=1e-15)
            np.testing.assert_allclose(lq @ lq.T, np.eye(f.order) - ref @ ref.T, rtol=1e-9, atol=1e-15)
