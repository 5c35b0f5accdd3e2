"""The per-step kernels against the readable models they reproduce, at 1e-12 relative (issue #31 item 2)."""

from __future__ import annotations

import numpy as np

from visnav.measurements import Controls
from visnav.vehicles.base import Environment
from visnav.vehicles.fixedwing import FixedWingModel, FixedWingParams, derivatives
from visnav.vehicles.kernels import fixedwing_constants, fixedwing_derivatives


def _draws(n=300, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        x = np.r_[rng.normal(0, 100, 3), rng.uniform(8, 30), rng.normal(0, 2, 2), rng.uniform(-1.2, 1.2),
                  rng.uniform(-0.9, 0.9), rng.uniform(-np.pi, np.pi), rng.normal(0, 0.5, 3)]
        u = Controls(*rng.uniform(-0.5, 0.5, 3), rng.uniform(0, 1))
        yield x, u, rng.normal(0, 5, 3)


def test_fixedwing_derivatives_equal_the_readable_model():
    """State derivative and air data (Va, alpha, beta, specific force) at 1e-12 relative."""
    p = FixedWingParams()
    gam = p.gammas()
    k = fixedwing_constants(p, gam)
    worst = 0.0
    for x, u, w in _draws():
        ref, ref_air = derivatives(p, x, u, w, gam)
        got, got_air = fixedwing_derivatives(k, x.tolist(), (u.aileron, u.elevator, u.rudder, u.throttle),
                                             w.tolist(), air=True)
        ref = np.r_[ref, ref_air["Va"], ref_air["alpha"], ref_air["beta"], ref_air["specific_force"]]
        got = np.r_[got, got_air[:3], got_air[3]]
        worst = max(worst, float(np.max(np.abs(got - ref) / np.maximum(np.abs(ref), 1e-9))))
    assert worst < 1e-12, worst


def test_a_flight_on_the_kernel_is_the_readable_flight():
    """300 RK4 steps (3 s) with varying controls and wind: the same trajectory to 1e-12 relative, step by step."""
    p = FixedWingParams()
    x0 = np.r_[0.0, 0.0, -100.0, 17.0, 0.0, 0.5, 0.0, 0.03, 0.3, 0.0, 0.0, 0.0]
    a, b = FixedWingModel(p, x0.copy()), FixedWingModel(p, x0.copy(), kernel=False)
    rng = np.random.default_rng(1)
    for k in range(300):
        u = Controls(*rng.uniform(-0.2, 0.2, 3), rng.uniform(0.3, 0.8))
        env = Environment(wind_ned=rng.normal(0, 3, 3))
        a.step(u, 0.01, env)
        b.step(u, 0.01, env)
        np.testing.assert_allclose(a.x, b.x, rtol=1e-12, atol=1e-12 * 100.0)
        np.testing.assert_allclose(a.state.specific_force, b.state.specific_force, rtol=1e-12, atol=1e-12)
        assert abs(a.air["Va"] - b.air["Va"]) <= 1e-12 * b.air["Va"]
    assert np.linalg.norm(a.x[0:3] - x0[0:3]) > 40.0  # it flew


def test_rmax_derivatives_equal_the_readable_model():
    from visnav.vehicles.kernels import rmax_derivatives
    from visnav.vehicles.rmax import RmaxModel, RmaxParams

    rng = np.random.default_rng(2)
    for damping in ("yacs", "full"):
        m = RmaxModel(RmaxParams(heave_damping=damping))
        worst = 0.0
        for _ in range(300):
            y = np.r_[rng.normal(0, 5, 3), rng.normal(0, 50, 2), rng.uniform(-30, 0), rng.uniform(-np.pi, np.pi),
                      rng.normal(0, 1)]
            att = (*rng.uniform(-0.4, 0.4, 2), *rng.normal(0, 0.5, 3), rng.normal(0, 0.2))
            w = rng.normal(0, 5, 3)
            ref = np.r_[m._deriv(y, att, w)]
            got = np.r_[rmax_derivatives(m.params, y.tolist(), att, w.tolist(), force=True)]
            worst = max(worst, float(np.max(np.abs(got - ref) / np.maximum(np.abs(ref), 1e-9))))
        assert worst < 1e-12, (damping, worst)


def test_an_rmax_flight_on_the_kernel_is_the_readable_flight():
    """10 s of commands and wind (climb, manoeuvre, descent to touchdown): the same states to 1e-12, step by step."""
    from visnav.measurements import YacsCommand
    from visnav.vehicles.rmax import RmaxModel

    a, b = RmaxModel(), RmaxModel()
    b.kernel = False
    rng = np.random.default_rng(3)
    for k in range(1000):
        thr = 250.0 if k < 300 else (-300.0 if k > 600 else 0.0)  # climb, hold, sink (YACS units, +-500)
        cmd = YacsCommand(0.01 * k, *rng.uniform(-150.0, 150.0, 3), thr)
        env = Environment(wind_ned=rng.normal(0, 2, 3))
        sa, sb = a.step(cmd, environment=env), b.step(cmd, environment=env)
        np.testing.assert_allclose(sa.position, sb.position, rtol=1e-12, atol=1e-11)
        np.testing.assert_allclose(sa.velocity, sb.velocity, rtol=1e-12, atol=1e-11)
        np.testing.assert_allclose(sa.specific_force, sb.specific_force, rtol=1e-12, atol=1e-11)
        assert a.on_ground == b.on_ground
    assert np.linalg.norm(sa.position) > 1.0  # it flew


def test_the_kernel_is_compiled_exactly_where_numba_is_installed_and_not_switched_off():
    """``make install`` installs the ``fast`` extra: the fixed wing then steps through numba's compiled kernel (a
    dispatcher with ``py_func``); without numba, or with VISNAV_JIT=0, through the plain function."""
    import importlib.util
    import os

    from visnav.vehicles import kernels

    compiled = importlib.util.find_spec("numba") is not None and os.environ.get("VISNAV_JIT", "1") != "0"
    assert (kernels.njit is not None) == compiled
    assert hasattr(kernels._fixedwing, "py_func") == compiled
    assert hasattr(kernels._rmax, "py_func") == compiled  # the R-MAX's RK4 step likewise


def test_the_kernel_on_python_floats_equals_the_readable_model():
    """VISNAV_JIT=0 (or no numba): the same kernel source on floats, in a fresh interpreter, at 1e-12."""
    from tests.jit_off import run_without_jit

    run_without_jit("import numpy as np\n"
                    "from visnav.vehicles import kernels\n"
                    "assert kernels.njit is None and not hasattr(kernels._fixedwing, 'py_func')\n"
                    "import tests.vehicles.test_kernels as t\n"
                    "t.test_fixedwing_derivatives_equal_the_readable_model()\n"
                    "t.test_a_flight_on_the_kernel_is_the_readable_flight()\n"
                    "t.test_rmax_derivatives_equal_the_readable_model()\n"
                    "t.test_an_rmax_flight_on_the_kernel_is_the_readable_flight()\n"
                    "print('ok')\n")
