"""Sensor-delay identification from phase slopes (seed 000 Figs. 5.2-5.4)."""

import math

import numpy as np
import pytest
from scipy import signal

from visnav.analysis.delay_id import camera_attitude, identify_delay, identify_delay_series, laser_attitude
from visnav.estimation.mpe import MonocularPositionEstimator
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm


def _delayed_pair(delay_s, rng, fs=100.0, n=6000, up=10, noise=0.05):
    """A band-limited signal and a copy ``delay_s`` late (exact on a grid 10x finer)."""
    x = signal.lfilter(*signal.butter(4, 3.0, fs=fs * up), rng.standard_normal(n * up + 2000))
    k = int(round(delay_s * fs * up))
    ref = x[1000::up][:n] + noise * rng.standard_normal(n)
    late = x[1000 - k::up][:n] + noise * rng.standard_normal(n)
    return ref, late


@pytest.mark.parametrize("delay", [0.044, 0.0, -0.044])
def test_delay_from_phase_slope(delay):
    rng = np.random.default_rng(3)
    ref, late = _delayed_pair(delay, rng)
    d = identify_delay(ref, late, 100.0, 0.3, 3.0)
    assert d.ok and d.n_bins >= 10
    assert d.delay_s == pytest.approx(delay, abs=0.002)
    assert d.std_s < 0.002


def test_delay_between_a_10hz_camera_and_a_100hz_imu():
    rng = np.random.default_rng(4)
    ref, late = _delayed_pair(0.044, rng, noise=0.02)
    t = np.arange(ref.size) / 100.0
    d = identify_delay_series(t[::10], ref[::10], t, late, 0.5, 2.5)
    assert d.delay_s == pytest.approx(0.044, abs=0.002)
    # no common signal: no delay
    assert not identify_delay(rng.standard_normal(2000), rng.standard_normal(2000), 100.0, 0.5, 3.0).ok


def test_camera_attitude_against_the_projection():
    # pure rotation (the lever arm turns a rotation partly into a translation: a gain, not a delay)
    cam, mount = PinholeCamera.ideal(640, 480, 1073.0), FixedMount.depressed(60.0)
    h = 12.0
    pos = np.array([-h / math.tan(math.radians(60.0)), 0.0, -h])
    point = np.zeros((1, 3))

    def pixel(euler):
        return cam.project(mount.world_to_camera(point, pos, euler_to_dcm(euler)))[0]

    uv0 = pixel(np.zeros(3))
    for axis, e in (("pitch", np.array([0.0, 0.01, 0.0])), ("roll", np.array([0.01, 0.0, 0.0]))):
        uv = pixel(e)
        ang = camera_attitude([uv0[0], uv[0]], [uv0[1], uv[1]], 1073.0, (320.0, 240.0), math.radians(60.0), axis)
        assert ang[1] - ang[0] == pytest.approx(0.01, rel=0.02)


def test_late_attitude_shifts_mpe_by_height_times_angle():
    """The term of ``model_loop``: MPE with attitude late by δ errs by +h·δθ in x, −h·δφ in y."""
    cam, mount = PinholeCamera.ideal(640, 480, 1073.0), FixedMount.depressed(60.0, lever_arm=(0.8, 0.0, -0.6))
    mpe = MonocularPositionEstimator(cam, mount, model="plane")
    h, d = 18.0, math.radians(0.5)
    pos = np.array([-h / math.tan(math.radians(60.0)), 0.0, -h])

    def look(euler):
        cam_pos, C_cn = mount.camera_pose(pos, euler_to_dcm(euler))
        uv = cam.project(mount.world_to_camera(np.zeros((1, 3)), pos, euler_to_dcm(euler)))[0]
        return uv, -cam_pos[2] / C_cn[2, 2]  # laser range along the optical axis

    uv, r = look(np.zeros(3))
    mpe.initialize(uv, r, euler_to_dcm(np.zeros(3)), pos)
    for e, k, sign in ((np.array([0.0, d, 0.0]), 0, 1.0), (np.array([d, 0.0, 0.0]), 1, -1.0)):
        uv, r = look(e)
        err = mpe.estimate(0.0, uv, r, euler_to_dcm(np.zeros(3))).position - pos
        assert err[k] == pytest.approx(sign * h * d, rel=0.05)




def test_laser_attitude_inverts_the_range_to_flat_ground():
    """R = h / sin(δ + o − θ) over flat ground (the beam along the optical axis, scan offsets o)."""
    rng = np.random.default_rng(5)
    dep, h = math.radians(60.0), 20.0
    theta = np.radians(2.0) * np.sin(np.linspace(0, 20, 400))
    off = np.radians(rng.choice([0.0, 1.0, -1.0], size=theta.size))
    r = h / np.sin(dep + off - theta)
    est = laser_attitude(r, off, dep)
    # up to a constant (the height is taken from the record's mean)
    assert np.std((est - est.mean()) - (theta - theta.mean())) < np.radians(0.02)


# ------------------------------------------------------------------ combining identifications (issue 30 item 5)
def test_combine_delays_weighted_mean_and_birge_inflation():
    from visnav.analysis.delay_id import combine_delays

    # consistent estimates: the inverse-variance mean, sigma (Σ 1/σ²)^-½, no inflation below R = 1
    c = combine_delays([0.090, 0.091, 0.0895], [0.001, 0.002, 0.001])
    w = np.array([1e6, 0.25e6, 1e6])
    assert c.delay_s == pytest.approx(np.sum(w * [0.090, 0.091, 0.0895]) / w.sum())
    chi2 = np.sum(w * (np.array([0.090, 0.091, 0.0895]) - c.delay_s) ** 2)
    assert c.birge_ratio == pytest.approx(math.sqrt(chi2 / 2))
    assert c.std_s == pytest.approx(w.sum() ** -0.5 * max(1.0, c.birge_ratio))
    assert c.n_used == 3 and c.n_rejected == 0
    # seeds scattering 10x their formal sigma: the sigma grows by the Birge ratio (≈ the sample sd / √n)
    d = np.array([0.080, 0.100, 0.085, 0.095])
    c = combine_delays(d, [0.001] * 4)
    assert c.delay_s == pytest.approx(d.mean())
    assert c.std_s == pytest.approx(d.std(ddof=1) / 2)
    assert c.confidence == pytest.approx(math.erf(0.005 / (math.sqrt(2) * c.std_s)))
    assert not c.usable(0.9) and combine_delays([0.09] * 4, [0.001] * 4).usable(0.9)


def test_combine_delays_drops_an_outlier_with_a_too_small_sigma():
    from visnav.analysis.delay_id import combine_delays

    # a laser sweep whose phase slope came from range noise: -133 ms "± 2 ms" among -8..-10 ms
    c = combine_delays([-0.0083, -0.133, -0.0095, -0.0090, -0.0102], [0.0022] * 5)
    assert c.n_rejected == 1 and c.n_used == 4
    assert c.delay_s == pytest.approx(np.mean([-0.0083, -0.0095, -0.0090, -0.0102]))
    # never the majority: two far apart groups keep the half nearer the weighted median
    c = combine_delays([0.0, 0.0, 0.1, 0.1, 0.1], [0.001] * 5)
    assert c.n_used >= 3 and c.delay_s == pytest.approx(0.1)


def test_combine_delays_edge_cases():
    from visnav.analysis.delay_id import combine_delays

    c = combine_delays([math.nan, 0.05], [0.001, math.nan])  # nothing usable
    assert math.isnan(c.delay_s) and c.confidence == 0.0 and c.n_used == 0 and not c.usable(0.0)
    c = combine_delays([0.05], [0.01])  # one estimate: its own sigma, confidence erf(0.5/√2)
    assert (c.delay_s, c.std_s, c.birge_ratio) == (0.05, 0.01, 1.0)
    assert c.confidence == pytest.approx(math.erf(0.5 / math.sqrt(2)))
    with pytest.raises(ValueError, match="one length"):
        combine_delays([0.1, 0.2], [0.01])
    with pytest.raises(ValueError, match="tolerance_s"):
        combine_delays([0.1], [0.01], tolerance_s=0)
