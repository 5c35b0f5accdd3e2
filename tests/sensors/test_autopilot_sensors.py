"""The fixed-wing autopilot's sensors (sensors/autopilot.py, baro.Compass, gps.Gps as CONDOR builds them):
noise and bias statistics against their configuration; time stamps; the CONDOR GPS noise as configured."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from visnav.measurements import VehicleState
from visnav.scenarios.schema import load_scenario
from visnav.sensors.autopilot import Ahrs, AutopilotImu, Pitot
from visnav.sensors.baro import Compass
from visnav.sensors.gps import Gps
from visnav.app.missions import make_simulation

S = VehicleState(0.0, np.array([10.0, -5.0, -100.0]), np.array([17.0, 1.0, 0.0]), np.array([0.3, 0.05, 1.0]),
                 np.array([0.01, 0.02, 0.15]), np.array([0.1, 0.2, -9.9]))
WORLD = SimpleNamespace(airspeed=lambda t: 17.0)
N = 4000


def truth_at(t):
    return S


def _draw(sensor, field):
    return np.array([np.atleast_1d(getattr(sensor.sample(k * 0.02, truth_at, WORLD), field)) for k in range(N)])


def test_ahrs_noise_and_bias():
    a = Ahrs(np.random.default_rng(1), noise_deg=0.2, bias_deg=0.5, yaw_noise_deg=1.0, yaw_bias_deg=2.0)
    m = a.sample(0.7, truth_at)
    assert m.t == 0.7 and m.sensor == "ahrs"
    e = _draw(a, "euler") - S.euler
    np.testing.assert_allclose(e.std(axis=0), np.radians([0.2, 0.2, 1.0]), rtol=0.05)
    np.testing.assert_allclose(e.mean(axis=0), a.bias, atol=4 * np.radians(1.0) / math.sqrt(N))
    # the turn-on bias is a draw of the configured spread (over many units)
    b = np.array([Ahrs(np.random.default_rng(s)).bias for s in range(2000)])
    np.testing.assert_allclose(b.std(axis=0), np.radians([0.5, 0.5, 2.0]), rtol=0.06)


def test_gyro_and_accelerometer_noise_and_bias():
    imu = AutopilotImu(np.random.default_rng(2), gyro_noise_deg_s=0.05, gyro_bias_deg_s=0.05, accel_noise_mps2=0.03,
                       accel_bias_mps2=0.05)
    g, f = _draw(imu, "gyro") - S.body_rates, _draw(imu, "accel") - S.specific_force
    np.testing.assert_allclose(g.std(axis=0), math.radians(0.05), rtol=0.05)
    np.testing.assert_allclose(f.std(axis=0), 0.03, rtol=0.05)
    np.testing.assert_allclose(g.mean(axis=0), imu.gyro_bias, atol=4 * math.radians(0.05) / math.sqrt(N))
    np.testing.assert_allclose(f.mean(axis=0), imu.accel_bias, atol=4 * 0.03 / math.sqrt(N))
    b = np.array([AutopilotImu(np.random.default_rng(s)).accel_bias for s in range(2000)])
    np.testing.assert_allclose(b.std(axis=0), 0.05, rtol=0.06)


def test_pitot_and_compass():
    p = Pitot(np.random.default_rng(3), noise_mps=0.2, bias_mps=0.3)
    v = _draw(p, "airspeed")[:, 0] - 17.0
    assert v.std() == pytest.approx(0.2, rel=0.05) and v.mean() == pytest.approx(p.bias, abs=4 * 0.2 / math.sqrt(N))
    c = Compass(np.random.default_rng(4), sigma_deg=1.0, bias_deg=2.0)
    h = _draw(c, "heading")[:, 0] - S.euler[2]
    assert h.std() == pytest.approx(math.radians(1.0), rel=0.05)
    assert h.mean() == pytest.approx(c.bias, abs=4 * math.radians(1.0) / math.sqrt(N))


@pytest.mark.parametrize("gps_noise_m", [1.0, 2.5])
def test_condor_gps_noise_is_the_configured_one(gps_noise_m):
    """The configured ``mission.gps_noise_m`` is the horizontal 1-sigma of the GPS CONDOR flies its loiter on
    (the old loop applied a tenth of it)."""
    sim = make_simulation(load_scenario("condor-orbit", [f"mission.gps_noise_m={gps_noise_m}"]))
    gps = [s for s in sim.sensors.values() if isinstance(s, Gps)]
    assert len(gps) == 1
    e = _draw(gps[0], "position")[:, :2] - S.position[:2]
    np.testing.assert_allclose(e.std(axis=0), gps_noise_m, rtol=0.05)
    np.testing.assert_allclose(e.mean(axis=0), 0.0, atol=4 * gps_noise_m / math.sqrt(N))
    assert gps[0].sample(1.0, truth_at).sigma == gps_noise_m


def test_condor_sensors_follow_the_contract():
    sim = make_simulation(load_scenario("condor-orbit"))
    for s in sim.sensors.values():
        assert s.rate_hz > 0 and s.latency_s >= 0, type(s).__name__
