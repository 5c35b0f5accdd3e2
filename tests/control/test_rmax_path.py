"""PFCM outer loop (seed 002 eq. 4.25) on the R-MAX: design, signs and units, limits, closed loop."""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np
import pytest

from visnav.control.rmax import CLIMB_GAIN, PITCH_DC, ROLL_DC, YAW_RATE_DC
from visnav.control.rmax_path import PathFollowingController, PathLoopGains, design_path_loop
from visnav.control.rmax_path import _clip, heading_rotation  # the issue #19 reference below
from visnav.control.rmax_path import PathReference, YacsCommand
from visnav.guidance.hermite import HermitePath
from visnav.guidance.pfcm import PfcmGuidance, PfcmLimits, PointHold
from visnav.measurements import NavEstimate, VehicleState
from visnav.vehicles.rmax import RmaxModel

G = 9.81


def _nav(p, v=(0, 0, 0), yaw=0.0, t=0.0):
    return NavEstimate(t=t, position=np.asarray(p, float), velocity=np.asarray(v, float),
                       attitude=np.array([0.0, 0.0, yaw]))


@pytest.fixture(scope="module")
def design():
    return design_path_loop()


def test_design_reproduces_the_default_gains_with_margins(design):
    d, g0 = design.gains, PathLoopGains()
    for f in fields(PathLoopGains):
        if f.name.startswith("k"):
            assert getattr(d, f.name) == pytest.approx(getattr(g0, f.name), rel=1e-4, abs=1e-9), f.name
    for axis in ("lateral", "longitudinal"):
        m = design.margins[axis]
        assert m.pm_deg == pytest.approx(45.0, abs=0.5) and m.gm_db >= 6.0
    assert design.margins["vertical"].pm_deg == pytest.approx(60.0, abs=0.5)
    assert design.margins["vertical"].w_gc == pytest.approx(2.0, rel=0.01)
    assert design.margins["yaw"].w_gc == pytest.approx(1.0, rel=0.01)
    # the 50 Hz loop is stiffer than the 10 Hz PALACE loop (less sample-and-hold delay)
    from visnav.control.rmax import RmaxPositionGains
    assert d.k1r > RmaxPositionGains().kp_lat


def test_yacs_unit_gains():
    g = PathLoopGains()
    u = g.yacs_units()
    assert u["K1r"] == pytest.approx(math.degrees(g.k1r / G) / ROLL_DC)
    assert u["K2p"] == pytest.approx(math.degrees(g.k2p / G) / PITCH_DC)
    assert u["K1t"] == pytest.approx(g.k1t / CLIMB_GAIN)
    assert u["K1y"] == pytest.approx(math.degrees(g.k1y) / YAW_RATE_DC)


def _straight_reference(v_target=0.0, position=(0.0, 0.0, -20.0)):
    """A PathReference on a straight north path (from a hold, then edited)."""
    import dataclasses

    r = PointHold(position, 0.0).step(0.0, _nav(position))
    return dataclasses.replace(r, velocity=np.array([v_target, 0.0, 0.0]), v_target=v_target)


def test_signs_and_units_of_eq_4_25():
    g = PathLoopGains(pitch_feedforward=False, load_factor_feedforward=False)
    c = PathFollowingController(g)
    # the helicopter 1 m right of and 0.5 m above the path, heading north, hovering
    cmd = c.command(0.0, _nav([0.0, 1.0, -20.5]), _straight_reference())
    assert cmd.ail == pytest.approx(math.degrees(-g.k1r * 1.0 / G) / ROLL_DC)  # roll left
    assert cmd.thr == pytest.approx(-g.k1t * 0.5 / CLIMB_GAIN)  # descend
    assert cmd.ele == 0.0 and cmd.rud == 0.0
    # slower than the target: pitch down (negative θ) by K2p δv_x / g
    c.reset()
    cmd = c.command(0.0, _nav([0.0, 0.0, -20.0], v=[3.0, 0, 0]), _straight_reference(v_target=5.0))
    assert cmd.ele == pytest.approx(math.degrees(-g.k2p * 2.0 / G) / PITCH_DC)
    # heading 10 deg left of the path: yaw right
    c.reset()
    cmd = c.command(0.0, _nav([0.0, 0.0, -20.0], yaw=math.radians(-10)), PointHold([0, 0, -20], 0.0))
    assert cmd.rud == pytest.approx(math.degrees(g.k1y * math.radians(10)) / YAW_RATE_DC)


def test_rotation_into_the_heading_frame():
    g = PathLoopGains(pitch_feedforward=False, load_factor_feedforward=False)
    c = PathFollowingController(g)
    # heading east; the helicopter 1 m north of the hold point = 1 m to its left: roll right
    cmd = c.command(0.0, _nav([1.0, 0.0, -20.0], yaw=math.pi / 2), PointHold([0, 0, -20], math.pi / 2))
    assert cmd.ail == pytest.approx(math.degrees(g.k1r / G) / ROLL_DC)
    assert cmd.ele == pytest.approx(0.0, abs=1e-9)


def test_limits_and_saturation_time():
    g = PathLoopGains()
    c = PathFollowingController(g)
    far = _nav([0.0, 100.0, -20.0])
    for k in range(51):  # 1 s at 50 Hz, 100 m off the path
        cmd = c.command(k * 0.02, far, PointHold([0, 0, -20], 0.0))
    assert math.radians(abs(cmd.ail) * ROLL_DC) == pytest.approx(g.max_roll)
    assert c.saturation_time_s == pytest.approx(1.0) and c.channel_saturation_s["ail"] == pytest.approx(1.0)
    assert c.channel_saturation_s["ele"] == 0.0
    assert np.linalg.norm(c._i_lat) == 0.0  # no wind-up while saturated


def test_bad_input():
    with pytest.raises(ValueError, match="k1r must be finite and >= 0"):
        PathLoopGains(k1r=-1.0)
    with pytest.raises(ValueError, match="rate_hz"):
        PathFollowingController(rate_hz=0.0)
    c = PathFollowingController()
    with pytest.raises(ValueError, match="nav.position must be 3 finite values"):
        c.command(0.0, _nav([np.nan, 0, 0]), PointHold([0, 0, -20], 0.0))
    with pytest.raises(ValueError, match="PathReference"):
        c.command(0.0, _nav([0, 0, -20]), object())


def test_closed_loop_on_the_model_follows_a_turn():
    """Guidance + eq. 4.25 at 50 Hz on the R-MAX model with perfect navigation (no wind):
    a 90 deg turn of 30 m radius at 5 m/s, about 25 s."""
    P = [[0, 0, -20], [20, 0, -20], [41.2132, 8.7868, -20], [50, 30, -20], [50, 45, -20]]
    T = [[1, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 1, 0]]
    path = HermitePath.from_waypoints(P, T)
    guide = PfcmGuidance(path, PfcmLimits(v_cruise=5.0))
    ctrl = PathFollowingController()
    init = VehicleState(t=0.0, position=np.array(P[0], float), velocity=np.zeros(3), euler=np.zeros(3),
                        body_rates=np.zeros(3), specific_force=np.array([0, 0, -G]))
    heli = RmaxModel(dt=0.01, initial=init)
    cmd, err, roll = None, [], []
    for k in range(3000):
        st = heli.state
        if k % 2 == 0:
            nav = NavEstimate(t=k * 0.01, position=st.position, velocity=st.velocity, attitude=st.euler)
            cmd = ctrl.command(k * 0.01, nav, guide)
            err.append(np.linalg.norm(guide.last.position - st.position))
            roll.append(st.euler[0])
            if guide.last.finished:
                break
        heli.step(cmd, 0.01)
    assert guide.last.finished or guide.last.distance_to_end < 0.5
    assert max(err) < 0.3 and np.sqrt(np.mean(np.square(err))) < 0.15
    # the bank of the trimmed turn: tan(phi) = v²/(g R) = 4.9 deg
    assert math.degrees(max(roll)) == pytest.approx(math.degrees(math.atan(25 / (G * 30))), abs=1.0)


class _ControllerReference(PathFollowingController):
    """``PathFollowingController.command`` before issue #19 (numpy scalars from dp / dv), the reference."""

    def command(self, t: float, nav: NavEstimate, ref) -> YacsCommand:
        r = ref.step(t, nav) if hasattr(ref, "step") else ref
        if not isinstance(r, PathReference):
            raise ValueError(f"reference must be a PathReference or a generator of them, got {type(r).__name__}")
        for name, arr in (("nav.position", nav.position), ("nav.velocity", nav.velocity),
                          ("nav.attitude", nav.attitude)):
            if np.shape(arr) != (3,) or not math.isfinite(float(arr[0] + arr[1] + arr[2])):
                raise ValueError(f"{name} must be 3 finite values, got {arr}")
        dt = 0.0 if self._last_t is None else min(max(t - self._last_t, 0.0), 5.0 / self.rate_hz)
        self._last_t = t
        self.last_reference = r
        k = self.gains
        psi = float(nav.attitude[2])
        C = heading_rotation(psi)
        xb, yb = C[0], C[1]  # body x and y axes in NED (rows of the NED -> heading rotation)
        dp = C @ (np.asarray(r.position, float) - np.asarray(nav.position, float))
        dv = C @ (np.asarray(r.velocity, float) - np.asarray(nav.velocity, float))
        if not k.world_integrators:  # body-frame integrators: re-express the stored ones on the new axes
            self._i_lon = xb * (xb @ self._i_lon)
            self._i_lat = yb * (yb @ self._i_lat)
        # d δv_x/dt, first-order low-pass
        if self._dvx_prev is not None and dt > 0:
            a = dt / (k.derivative_tau + dt)
            self._dvx_rate += a * ((dv[0] - self._dvx_prev) / dt - self._dvx_rate)
        self._dvx_prev = float(dv[0])
        # pitch and roll (accelerations), eq. 4.25 (+ the lateral integral)
        i_x, i_y = float(xb @ self._i_lon), float(yb @ self._i_lat)
        a_x = k.k1p * dp[0] + k.k2p * dv[0] + k.k3p * self._dvx_rate + k.k4p * i_x
        a_y = k.k1r * dp[1] + k.k2r * dv[1] + k.k3r * i_y
        theta_ff = (k.drag_xu * r.v_target - r.accel_target) / G if k.pitch_feedforward else 0.0
        theta_raw = theta_ff - a_x / G
        phi_raw = r.phi_ff + a_y / G
        theta_c = _clip(theta_raw, -k.max_pitch, k.max_pitch)
        phi_c = _clip(phi_raw, -k.max_roll, k.max_roll)
        # throttle: climb-rate command [m/s] (h up = −z)
        dh, dhd = -dp[2], -dv[2]
        climb_ff = -float(r.velocity[2]) if k.climb_feedforward else 0.0
        if k.load_factor_feedforward:  # T_ff of eq. 4.14 as the climb rate the YACS must hold
            climb_ff += G * (1.0 / math.cos(r.phi_ff) - 1.0) / k.heave_damping
        w_raw = climb_ff + k.k1t * dh + k.k2t * dhd + k.k3t * self._i_z
        w_c = _clip(w_raw, -k.max_climb_rate, k.max_climb_rate)
        r_raw = r.r_ff + k.k1y * r.heading_error
        r_c = _clip(r_raw, -k.max_yaw_rate, k.max_yaw_rate)
        lim = k.input_limit
        roll_cmd = math.degrees(phi_c)  # open-loop DC inversion (eq. 4.25) ...
        if self._roll is not None:  # ... or the eq. 4.26 inner loop on the INS roll
            e = math.degrees(phi_c - float(nav.attitude[0]))
            if not self._roll.started:  # bumpless start: first output = the DC inversion
                self._roll.reset(e, roll_cmd)
            elif dt > 0:
                roll_cmd = self._roll.step(e)
            else:
                roll_cmd = self._roll.last
        raw = (roll_cmd / ROLL_DC, math.degrees(theta_c) / PITCH_DC, math.degrees(r_c) / YAW_RATE_DC,
               w_c / CLIMB_GAIN)
        # a channel is saturated when its YACS input is at ±input_limit or its command limit acts
        sat = (abs(raw[0]) >= lim or phi_raw != phi_c, abs(raw[1]) >= lim or theta_raw != theta_c,
               abs(raw[2]) >= lim or r_c != r_raw, abs(raw[3]) >= lim or w_raw != w_c)
        # integrators: conditional integration (anti-windup) and clamping
        if dt > 0:
            if not sat[1]:
                self._i_lon = self._clamp(self._i_lon + xb * (dv[0] * dt), k.k4p, k.integral_limit)
            if not sat[0]:
                self._i_lat = self._clamp(self._i_lat + yb * (dp[1] * dt), k.k3r, k.integral_limit)
            if not sat[3] and k.k3t > 0:
                self._i_z = _clip(self._i_z + dhd * dt, -k.max_climb_rate / k.k3t, k.max_climb_rate / k.k3t)
            if any(sat):
                self.saturation_time_s += dt
            for c, flag in zip(self.channel_saturation_s, sat):
                self.channel_saturation_s[c] += dt if flag else 0.0
        self.attitude_command = np.array([phi_c, theta_c])
        if hasattr(ref, "set_lateral_bias"):  # the roll the wind correction costs, for v_targ2
            ref.set_lateral_bias(k.k3r * self._i_lat[:2])
        cmd = YacsCommand(t=t, ail=_clip(raw[0], -lim, lim), ele=_clip(raw[1], -lim, lim),
                          rud=_clip(raw[2], -lim, lim), thr=_clip(raw[3], -lim, lim))
        if self.record is not None:
            self.record("pfcm_control", t, phi_c=phi_c, theta_c=theta_c, climb_c=w_c, yaw_rate_c=r_c,
                        ail=cmd.ail, ele=cmd.ele, rud=cmd.rud, thr=cmd.thr, dp=dp, dv=dv, i_x=i_x, i_y=i_y,
                        phi_ff=r.phi_ff, sat_ail=sat[0], sat_ele=sat[1],
                        sat_rud=sat[2], sat_thr=sat[3], dt=dt)
        return cmd


@pytest.mark.parametrize("compensator", [False, True])
def test_command_equals_the_reference_bit_for_bit(compensator):
    """A noisy flight along a turning PFCM path (saturating now and then): the live command, its log row and the
    controller's state equal the reference's to the bit."""
    path = HermitePath.from_waypoints([[0, 0, -20], [60, 0, -20], [90, 40, -26]], [[1, 0, 0], [1, 0, 0], [0, 1, 0]])
    gains = PathLoopGains.with_roll_compensator() if compensator else PathLoopGains()
    rows = {"new": [], "old": []}
    ctl = {name: cls(gains, recorder=lambda s, t, _n=name, **kw: rows[_n].append((s, t, kw)))
           for name, cls in (("new", PathFollowingController), ("old", _ControllerReference))}
    refs = {name: PfcmGuidance(path, PfcmLimits(v_cruise=6.0)) for name in ctl}
    rng = np.random.default_rng(3)
    p, v = np.array([0.0, 0.0, -20.0]), np.zeros(3)
    for k in range(3000):
        t = 0.02 * k + (0.02 if k % 97 == 0 else 0.0)  # now and then the same instant twice (dt = 0)
        nav = NavEstimate(t=t, position=p + rng.normal(0, 0.4 if k % 300 else 8.0, 3), velocity=v + rng.normal(0, 0.3, 3),
                          attitude=np.array([rng.normal(0, 0.1), rng.normal(0, 0.1), rng.normal(0, 0.3)]))
        got, want = ctl["new"].command(t, nav, refs["new"]), ctl["old"].command(t, nav, refs["old"])
        assert repr(got) == repr(want)
        r = refs["old"].last
        p, v = r.position + rng.normal(0, 1.0, 3), r.velocity
    assert len(rows["new"]) == len(rows["old"]) == 3000
    for (s1, t1, a), (s2, t2, b) in zip(rows["new"], rows["old"]):
        assert s1 == s2 and t1 == t2 and a.keys() == b.keys()
        for key in a:
            assert np.asarray(a[key]).tobytes() == np.asarray(b[key]).tobytes(), key
    for name in ("_i_lon", "_i_lat", "_i_z", "_dvx_prev", "_dvx_rate", "saturation_time_s", "attitude_command"):
        assert np.asarray(getattr(ctl["new"], name)).tobytes() == np.asarray(getattr(ctl["old"], name)).tobytes()
    assert ctl["new"].channel_saturation_s == ctl["old"].channel_saturation_s
    assert ctl["new"].saturation_time_s > 0
