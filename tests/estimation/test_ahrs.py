"""AHRS mode of the error-state filter on synthetic IMU data with exact truth."""

import math

import numpy as np
import pytest

from visnav.estimation.ahrs import AhrsConfig, attitude_differences, run_ahrs
from visnav.geometry.rotations import euler_to_dcm
from visnav.sim.trajectory import SinusoidTrajectory

D2R = math.pi / 180


def _flight():
    """Attitude swings (+-8 deg roll/pitch, yaw sweeping 40 deg) with small translational
    accelerations (0.04 m/s^2: the gravity aid cannot tell them from tilt, 0.23 deg)."""
    return SinusoidTrajectory(p_amp=((1.0, 1.0, 0.5),), p_freq=(0.2,), e0=(0.0, 0.0, 1.0),
                              e_amp=((0.14, 0.14, 0.35),), e_freq=(0.25,), e_phase=((0.0, 1.2, 0.4),))


def test_ahrs_tracks_truth_with_gyro_bias_and_magnetometer():
    rng = np.random.default_rng(0)
    dt = 0.004
    t = np.arange(0.0, 30.0, dt)
    d = _flight().sample(t)
    bg = np.array([0.004, -0.003, 0.002])  # 0.2 deg/s gyro biases
    gyro = d["gyro"] + bg + rng.normal(0, 2e-3 / math.sqrt(dt), d["gyro"].shape)
    accel = d["specific_force"] + rng.normal(0, 0.02 / math.sqrt(dt), d["gyro"].shape)
    m_ned = np.array([0.2, 0.01, 0.45])
    decl = math.degrees(math.atan2(m_ned[1], m_ned[0]))
    tm = t[::25]
    mag = np.einsum("nji,j->ni", euler_to_dcm(d["euler"][::25]), m_ned) + rng.normal(0, 0.003, (len(tm), 3))
    res = run_ahrs(t, accel, gyro, tm, mag, AhrsConfig(accel_noise=0.02, declination_deg=decl, gravity_mps2=9.81))
    cmp = attitude_differences(t, res["euler"], t[t > 10], d["euler"][t > 10])
    assert cmp["roll_rms_diff_deg"] < 0.5 and cmp["pitch_rms_diff_deg"] < 0.5, cmp
    assert cmp["yaw_rms_diff_deg"] < 1.5, cmp
    np.testing.assert_allclose(res["gyro_bias"], bg, atol=1e-3)
    assert res["stats"]["gravity"][0] > 100 and res["stats"]["heading"][0] > 100


def test_without_aids_the_gyro_bias_drifts_the_attitude():
    """Control: the same data with every gravity update refused (tolerance 0) drifts by the
    integrated gyro bias, 0.2 deg/s x 30 s = 6 deg on roll."""
    dt = 0.004
    t = np.arange(0.0, 30.0, dt)
    d = _flight().sample(t)
    bg = np.array([0.0035, 0.0, 0.0])
    res = run_ahrs(t, d["specific_force"], d["gyro"] + bg, cfg=AhrsConfig(accel_tol_mps2=0.0, gravity_mps2=9.81))
    assert "gravity" not in res["stats"]
    err = abs(res["euler"][-1, 0] - d["euler"][-1, 0]) / D2R
    assert err == pytest.approx(math.degrees(0.0035 * 30.0), rel=0.15)


def test_too_short_input_is_refused():
    with pytest.raises(ValueError, match="at least"):
        run_ahrs(np.arange(5) * 0.01, np.zeros((5, 3)), np.zeros((5, 3)))
