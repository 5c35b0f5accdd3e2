import numpy as np
import pytest

from visnav.measurements import VehicleState
from visnav.sensors.baro import Baro, Compass


def _truth(t):
    return VehicleState(t=t, position=np.array([0.0, 0.0, -60.0]), velocity=np.zeros(3),
                        euler=np.array([0.0, 0.0, 3.1]), body_rates=np.zeros(3), specific_force=np.zeros(3))


def test_baro_noise_and_gauss_markov_bias():
    b = Baro(np.random.default_rng(0), sigma_m=0.3, bias_sigma_m=0.5, bias_tau_s=50.0)
    alt = np.array([b.sample(k * 0.05, _truth).altitude for k in range(20000)])
    assert np.mean(alt) == pytest.approx(60.0, abs=0.5)
    # the drift has the configured stationary spread (0.5 m) on top of 0.3 m white noise
    slow = alt.reshape(-1, 100).mean(axis=1)
    assert np.std(slow) == pytest.approx(0.5, rel=0.35)
    assert np.std(np.diff(alt)) == pytest.approx(0.3 * np.sqrt(2), rel=0.05)


def test_compass_wraps():
    c = Compass(np.random.default_rng(1), sigma_deg=5.0, bias_deg=0.0)
    h = np.array([c.sample(0.0, _truth).heading for _ in range(2000)])
    assert np.all(np.abs(h) <= np.pi)
    assert np.angle(np.mean(np.exp(1j * h))) == pytest.approx(3.1, abs=0.01)
