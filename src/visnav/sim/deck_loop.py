"""Closed-loop ship-deck landing (seed 003): Y6 multirotor, IMU + forward camera, relative deck UKF, tau guidance.

One dynamics / IMU step of ``run.dt_s``; the camera frame every ``round(1 / (rate dt))`` steps, the
guidance and control every second step. Modes (logged in the ``mode`` stream):

* ``manual`` - before the hand-over (in §5.3.2 and §5.3.5 the vehicle was flown by hand while the
  estimator started and converged): with ``start.pilot = "imu"`` a level hover on the IMU alone, with
  ``"truth"`` a truth-based hold of the start point (the thesis' safety pilot); the filter runs. After
  ``start.manual_s`` the hand-over waits for the operator's check (§5.3.1): every frame of the last
  second with >= 3 lights and an RMS bearing innovation below ``filter.converged_bearing_rms_deg``;
  failing it, the filter restarts (as the thesis' operator reset it, Fig. 5.7) from the next relative
  yaw of ``filter.yaw_hypotheses_deg`` and the hold goes on;
* ``hover`` (moving deck) - autonomous hold on the estimates for at least ``hover_min_s``, until the
  start conditions of §5.3.5 hold (near the start point; predicted approach path within
  ``lambda_max_deg`` of the start azimuth and at least ``gamma_min_deg`` from vertical);
* ``approach`` - the tau trajectory (static: three straight gaps, k = 0.3, 15 s; moving: alpha,
  beta, rho gaps of ch. 4, re-aimed at every control step at the latest touchdown prediction);
* the last ``guidance.flare_s`` before contact of a moving-deck approach: the commanded specific force
  is turned onto the predicted deck normal (attitude before the position feedback, not in the thesis);
* a moving-deck trajectory that ends without contact goes around (back to ``hover`` at the start
  point, a new approach once the start conditions hold) up to ``guidance.go_arounds`` times;
* ``descend`` - past the trajectory's end without contact (static deck, or no go-around left): thrust
  along the estimated deck normal with the vertical speed servoed to ``final_descent_mps`` and a
  horizontal hold (not in the thesis, whose runs end at the trajectory's end);
* ``landed`` / ``missed`` - the gear met the deck plane on / off the plate; the run ends.

Truth reaches the control only as the ``"truth"`` pilot's hold in ``manual`` and the navigator only
with ``filter.init = "truth"``, as the initial estimate (the thesis' Vicon start).
"""

from __future__ import annotations

import time

import numpy as np

from visnav.control.multirotor import ThrottleController, attitude_command, follow
from visnav.estimation import deck as dm
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.rotations import dcm_to_euler, euler_to_dcm
from visnav.guidance.deck_approach import StraightApproach, TauGapApproach, predict_deck_attitude, touchdown_acceleration
from visnav.navigation.deck import DeckNavigator
from visnav.sensors.led_camera import LedCamera
from visnav.sim.log import FlightLog
from visnav.sim.streams import DECK_STREAMS
from visnav.sim.loop import RunResult
from visnav.vehicles.multirotor import AttitudeThrustCommand, Multirotor, MultirotorParams
from visnav.vision.blobs import BearingTracker, find_blobs
from visnav.world.deck import SEA_STATES, DeckMotion, validate_lights

G = 9.81
RENDER_CENTROID_PX = 0.025  # centroid error of the rendered spots alone (measured: 0.0033 deg at f = 420 px)
DIST_EQ_5_6_5_7 = (-0.188, -0.1631, 0.00136, 0.001605, 0.1631, 0.131, -0.366, 0.2436)  # OpenCV order


def camera_rotation(depression: float, yaw: float) -> np.ndarray:
    """T_cam: body FRD -> OpenCV camera axes for an optical axis ``depression`` below x, turned by ``yaw``."""
    zc = np.array([np.cos(depression) * np.cos(yaw), np.cos(depression) * np.sin(yaw), np.sin(depression)])
    xc = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
    return np.vstack([xc, np.cross(zc, xc), zc])


def _Rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class _Mode:
    """What the command line and the campaign runner read: ``sim.mission.mode``."""

    def __init__(self):
        self.mode = "manual"


class DeckSimulation:
    def __init__(self, scenario):
        self.sc = sc = scenario
        cfg = self.cfg = sc.mission
        self.dt = sc.run.dt_s
        self.log = FlightLog(schema=DECK_STREAMS)
        rng = [np.random.default_rng(s) for s in np.random.SeedSequence(sc.run.seed).spawn(8)]
        self.rng = rng
        d = cfg.deck
        self.lights = validate_lights(d.lights_m)
        self.landing_point = np.asarray(cfg.guidance.landing_point_m, float)
        if d.motion == "static":
            self.deck = DeckMotion.static()
        else:
            self.deck = DeckMotion.from_sea_state(d.sea_state, rng[0], d.sinusoids, d.motion_scale)
        h = d.size_m / 2
        self.deck_corners = np.array([[h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0], [-h, h, 0.0]])
        self.extra = np.asarray(cfg.camera.extra_blobs_deck_m, float).reshape(-1, 3)

        v = cfg.vehicle
        self.params = MultirotorParams(mass=v.mass_kg, thrust_to_weight=v.thrust_to_weight,
                                       attitude_omega=v.attitude_bandwidth_rad_s, attitude_zeta=v.attitude_damping,
                                       thrust_tau=v.thrust_time_constant_s, drag=v.drag_per_s, gear_offset=v.gear_offset_m)
        # start: behind the deck (azimuth 180 deg +- heading offset), camera pointing at the deck
        st = cfg.start
        dist = rng[1].uniform(st.distance_min_m, st.distance_max_m)
        elev = np.radians(rng[1].uniform(st.elevation_min_deg, st.elevation_max_deg))
        az = np.pi + np.radians(rng[1].uniform(-st.heading_offset_max_deg, st.heading_offset_max_deg))
        if d.motion == "moving":  # §5.3.5: nominally 1 m above and 1 m behind the deck
            dist, elev, az = np.sqrt(2.0), np.radians(45.0), np.pi
        rel = dist * np.array([np.cos(elev) * np.cos(az), np.cos(elev) * np.sin(az), -np.sin(elev)])
        d0 = self.deck.state(0.0)
        self.start_rel_ld = rel  # the hold point of the manual and hover modes (level-deck frame)
        yaw0 = np.arctan2(-rel[1], -rel[0]) + np.radians(rng[1].uniform(-5, 5))
        self.vehicle = Multirotor(self.params, d0.position + rel, yaw=yaw0)

        c = cfg.camera
        dist_coeffs = DIST_EQ_5_6_5_7 if c.distortion else (0.0,) * 8
        self.camera_model = PinholeCamera(c.width_px, c.height_px, c.focal_px, c.focal_px, (c.width_px - 1) / 2,
                                          (c.height_px - 1) / 2, dist_coeffs)
        T_cam = camera_rotation(np.radians(c.depression_deg), np.radians(c.yaw_deg))
        self.cam_geom = dm.CameraGeometry(rho=np.asarray(c.position_m, float), T_cam=T_cam)
        self.led_camera = LedCamera(self.camera_model, T_cam, self.cam_geom.rho, rng[2], noise_gray=c.noise_gray)
        self.tracker = BearingTracker(self.camera_model, threshold=c.blob_threshold)
        self._centroid_rng = rng[6]

        f = cfg.filter
        A, W, sA, sW = SEA_STATES[d.sea_state if d.motion == "moving" else "calm"]
        bound = dm.ship_acceleration_bound(A * d.motion_scale, W, sA * d.motion_scale, sW) * f.ship_accel_scale
        # white deck acceleration over a correlation time 1/omega, discretised at dt (eq. 3.8)
        ship_var = np.where(W > 0, bound**2 / np.maximum(W, 1e-6) / self.dt, 0.0)
        ship_var = np.maximum(ship_var, 1e-4)
        imu = cfg.imu
        imu_cov = np.diag([imu.accel_noise_mps2**2] * 3 + [imu.gyro_noise_rad_s**2] * 3) * f.imu_noise_scale**2
        imu_cov = imu_cov + np.diag([(G * np.radians(imu.attitude_noise_deg)) ** 2] * 3 + [0.0] * 3)
        x_true0 = self.truth_state(0.0, d0)
        if f.init == "static":
            x0, P0 = dm.initial_state_static()
        else:
            sig = np.repeat([0.03, np.radians(3), 0.05, np.radians(2)], 3)
            P0 = np.diag(sig**2)
            x0 = dm.wrap_state(x_true0 + sig * rng[3].standard_normal(12))
        # from eq. 5.12's far-off start the acquisition (manual flight, before the hand-over check) uses the
        # thesis' R and tracking the sensor's; from the truth (sigmas of cm and degrees) the sensor's throughout:
        # the thesis' 2 deg let a converged start drift off in pitch during the hover (moving seed 83)
        sig_acq = ((np.radians(f.acquisition_bearing_noise_deg), np.radians(f.acquisition_rate_noise_deg_s))
                   if f.init == "static" else self.measurement_sigmas())
        self.nav = DeckNavigator(self.lights, self.cam_geom, x0, P0, imu_cov, np.diag(ship_var), *sig_acq,
                                 f.gate, f.alpha, f.beta, f.kappa)
        self.log.record("filter_init", 0.0, x0=x0, sigma=np.sqrt(np.diag(P0)), source=f.init)
        self._x0, self._P0, self._n_restarts = x0, P0, 0
        hov = self.params.hover_throttle
        self.throttle = ThrottleController(hover_throttle_1m=hov, hover_throttle_ground=hov / self.params.ground_effect(
            v.gear_offset_m + self.params.rotor_height))
        self.mission = _Mode()
        self.approach = None
        self._go_arounds = 0
        self.t_mode = 0.0
        self.touchdown: dict | None = None
        self._ahrs = np.zeros(3)

    @property
    def frame_steps(self) -> int:
        """Steps between camera frames: ``camera.rate_hz`` rounded to a whole number of ``run.dt_s``."""
        return max(1, int(round(1.0 / (self.cfg.camera.rate_hz * self.dt))))

    def measurement_sigmas(self) -> tuple[float, float]:
        """Filter R [rad, rad/s]: the configured values, or those of the simulated camera (§3.1.2).

        A bearing is the centroid through the focal length, ``sigma_px / f``; a bearing rate the difference of
        two frames' bearings over the frame interval the loop realises, ``sqrt(2) sigma_b / (d_cam dt)``.
        """
        f, c = self.cfg.filter, self.cfg.camera
        sig_b = (np.radians(f.bearing_noise_deg) if f.bearing_noise_deg is not None
                 else np.hypot(c.centroid_noise_px, RENDER_CENTROID_PX) / c.focal_px)
        sig_r = (np.radians(f.bearing_rate_noise_deg_s) if f.bearing_rate_noise_deg_s is not None
                 else np.sqrt(2.0) * sig_b / (self.frame_steps * self.dt))
        return float(sig_b), float(sig_r)

    # --- truth ---------------------------------------------------------------------------------
    def truth_state(self, t: float, ds=None) -> np.ndarray:
        ds = ds or self.deck.state(t)
        s = self.vehicle.state
        Ch = euler_to_dcm(s.euler)
        r = Ch.T @ (ds.position - s.position)
        e = dcm_to_euler(ds.C.T @ Ch)
        v = Ch.T @ (ds.velocity - s.velocity) - np.cross(s.body_rates, r)
        return np.r_[r, e, v, ds.body_rates]

    # --- guidance and control ------------------------------------------------------------------
    def _relative(self, x: np.ndarray, gyro: np.ndarray, roll: float, pitch: float):
        """Vehicle relative to the deck in the heading-free level frame, deck attitude there, level-deck yaw."""
        Ch0 = euler_to_dcm([roll, pitch, 0.0])
        r, e, v, wd = x[0:3], x[3:6], x[6:9], x[9:12]
        p = -Ch0 @ r
        vel = -Ch0 @ (v + np.cross(gyro, r))
        Cd0 = Ch0 @ euler_to_dcm(e).T
        psi_d = float(dcm_to_euler(Cd0)[2])
        return p, vel, Cd0, psi_d, wd

    def _target(self, Cd0, wd, psi_d, t_go):
        """Touchdown target (body origin, level-deck frame) and the predicted upward deck normal there."""
        g = self.cfg.guidance
        moving = self.cfg.deck.motion == "moving"
        Cp = predict_deck_attitude(Cd0, wd, t_go) if moving else Cd0
        Rz = _Rz(psi_d)
        n_up = Rz.T @ (-Cp[:, 2])
        land = Rz.T @ (Cp @ self.landing_point)  # the desired landing location (§2.3), level-deck frame
        return land + (self.params.gear_offset - (g.overshoot_moving_m if moving else g.overshoot_m)) * n_up, n_up

    def _control(self, t: float, x: np.ndarray, gyro, roll, pitch, acc_meas_up, dt):
        g = self.cfg.guidance
        p, vel, Cd0, psi_d, wd = self._relative(x, gyro, roll, pitch)
        Rz = _Rz(psi_d)
        p_ld, v_ld = Rz.T @ p, Rz.T @ vel
        mode = self.mission.mode
        tm = t - self.t_mode
        a_ff = np.zeros(3)
        if mode in ("manual", "hover"):
            p_des, v_des = self.start_rel_ld, np.zeros(3)
            if mode == "manual" and tm >= self.cfg.start.manual_s:
                if self._converged(t):
                    self._begin(t, "hover" if self.cfg.deck.motion == "moving" else "approach", p_ld, Cd0, wd, psi_d)
                else:
                    self._restart_filter(t)
            elif mode == "hover":
                self._maybe_start(t, tm, p_ld, Cd0, wd, psi_d)
            if self.mission.mode == "manual" and self.cfg.start.pilot == "imu":
                # no truth: hover level on the IMU (vertical acceleration PI), heading held
                thr = self.throttle.command(0.0, acc_meas_up, 1.0, np.cos(roll) * np.cos(pitch), dt)
                self.log.record("reference", t, position=np.full(3, np.nan), velocity=np.zeros(3), accel=np.zeros(3))
                return AttitudeThrustCommand(t=t, roll=0.0, pitch=0.0, yaw_rate=0.0, throttle=thr)
        elif mode == "approach":
            if isinstance(self.approach, TauGapApproach):
                c, n_up = self._target(Cd0, wd, psi_d, max(self.approach.T - tm, 0.0))
                try:
                    a_td, _, _ = touchdown_acceleration(n_up, g.touchdown_accel_mps2)
                    # the prediction is noisy (deck rates x time to go): re-aim through a first-order filter
                    w = min(dt / g.retarget_tau_s, 1.0) if g.retarget_tau_s > 0 else 1.0
                    self._a_td = self._a_td + w * (a_td - self._a_td)
                    self.approach.retarget(self._a_td)
                except ValueError as exc:  # predicted deck too steep to match: keep the last aim, say so
                    self.log.record("retarget_skipped", t, reason=str(exc))
            else:
                c = self._c0
            pd, vd, a_now = self.approach.desired(tm)
            # the horizontal acceleration feed-forward is realised by tilting, through the attitude loop's lag:
            # take it that far ahead; the vertical one (thrust, fast) as it is
            _, _, a_lead = self.approach.desired(min(tm + g.feedforward_lead_s, self.approach.T))
            p_des, v_des, a_ff = c + pd, vd, np.array([a_lead[0], a_lead[1], a_now[2]])
            if tm >= self.approach.T:
                if isinstance(self.approach, TauGapApproach) and self._go_arounds < g.go_arounds:
                    # no contact at the trajectory's end: back to the start point, a new approach when the
                    # start conditions hold again (the descend mode would hold the matched tilt for too long)
                    self._go_arounds += 1
                    self._set_mode(t, "hover", f"trajectory ended without contact: go-around {self._go_arounds}")
                else:
                    self._set_mode(t, "descend", "trajectory ended without contact")
        else:  # descend: thrust along the deck normal (attitude matched), sink at final_descent_mps
            c, n_up = self._target(Cd0, wd, psi_d, 0.0)
            p_des, v_des = np.array([c[0], c[1], p_ld[2]]), np.array([0.0, 0.0, g.final_descent_mps])
            a_z = g.damper_per_s * (g.final_descent_mps - v_ld[2])
            a_ff = np.array([0.0, 0.0, G]) + (G - a_z) / max(-n_up[2], 0.5) * n_up
        if mode == "descend":  # optionally plus the spring-damper on the horizontal error (tilts the thrust)
            fb = follow(p_des, np.zeros(3), np.zeros(3), p_ld, v_ld, g.spring_per_s2, g.damper_per_s)
            a_cmd_ld = a_ff + (np.array([fb[0], fb[1], 0.0]) if g.descent_hold else 0.0)
        else:
            a_cmd_ld = follow(p_des, v_des, a_ff, p_ld, v_ld, g.spring_per_s2, g.damper_per_s)
        if mode in ("approach", "descend") and isinstance(self.approach, TauGapApproach) and g.flare_s > 0:
            # time to contact: gear height over the predicted deck plane / closing speed along its normal
            h = float(n_up @ (p_ld - c)) - g.overshoot_moving_m  # c: the body at contact, overshoot below
            closing = float(-(n_up @ v_ld))
            t_c = h / closing if closing > 1e-3 else np.inf
            if mode == "approach":
                t_c = min(t_c, self.approach.T - tm)
            a_cmd_ld = self._flare(a_cmd_ld, n_up, t_c)
        a_cmd = Rz @ a_cmd_ld
        Tm, phi, theta = attitude_command(a_cmd, np.radians(self.cfg.vehicle.max_tilt_deg))
        height = max(-p_ld[2] - self.params.gear_offset, 0.0)
        thr = self.throttle.command(-a_cmd[2], acc_meas_up, height, np.cos(roll) * np.cos(pitch), dt)
        r = x[0:3]
        yaw_rate = 1.0 * np.arctan2(r[1], r[0]) if np.hypot(r[0], r[1]) > 0.3 else 0.0
        self.log.record("reference", t, position=Rz @ p_des, velocity=Rz @ v_des, accel=a_cmd)
        return AttitudeThrustCommand(t=t, roll=phi, pitch=theta, yaw_rate=float(yaw_rate), throttle=thr)

    def _flare(self, a_cmd_ld: np.ndarray, n_up: np.ndarray, t_go: float) -> np.ndarray:
        """Attitude-matching flare: over the last ``guidance.flare_s`` before contact turn the thrust onto the deck normal.

        The feedback of eq. 4.25 tilts the thrust off the planned terminal acceleration (a_td along the
        predicted normal, eq. 4.1-4.3) to correct position and velocity errors; in the last fraction of a
        second attitude matters more than those errors, so the commanded specific force is blended, linearly
        in time, into one along ``n_up`` with the same vertical component (the vertical channel is kept).
        """
        w = float(np.clip(1.0 - t_go / self.cfg.guidance.flare_s, 0.0, 1.0))
        if w <= 0.0 or n_up[2] > -0.5:
            return a_cmd_ld
        f = a_cmd_ld - np.array([0.0, 0.0, G])  # specific force, level-deck frame (z down: f[2] < 0)
        matched = n_up * (f[2] / n_up[2]) + np.array([0.0, 0.0, G])
        return (1.0 - w) * a_cmd_ld + w * matched

    def _converged(self, t: float) -> bool:
        """The operator's check before hand-over (§5.3.1): lights tracked and bearings fit, last second."""
        c = self.log.get("camera")
        m = c["t"] > t - 1.0
        if m.sum() < 5 or np.any(c["lights_used"][m] < 3):
            return False
        rms = np.sqrt(np.nanmean(c["bearing_rms"][m] ** 2))
        return bool(rms <= np.radians(self.cfg.filter.converged_bearing_rms_deg))

    def _restart_filter(self, t: float) -> None:
        hyp = self.cfg.filter.yaw_hypotheses_deg
        if self._n_restarts >= len(hyp):
            raise RuntimeError("the deck filter did not converge from any initial yaw hypothesis")
        x0, P0 = self._x0.copy(), self._P0
        if self.cfg.filter.init == "truth":  # the Vicon start again, from where the vehicle is now
            sig = np.sqrt(np.diag(P0))
            x0 = dm.wrap_state(self.truth_state(t) + sig * self.rng[3].standard_normal(12))
            why = "restart from the truth"
        else:
            x0[5] = np.radians(hyp[self._n_restarts])
            why = f"restart from relative yaw {hyp[self._n_restarts]:.0f} deg"
        self._n_restarts += 1
        self.nav.reset(x0, P0)
        self.log.record("filter_init", t, x0=x0, sigma=np.sqrt(np.diag(P0)), source=f"restart {self._n_restarts}")
        self._set_mode(t, "manual", f"filter not converged: {why}")

    def _set_mode(self, t, mode, reason):
        self.mission.mode, self.t_mode = mode, t
        self.log.record("mode", t, mode=mode, reason=reason)

    def _begin(self, t, mode, p_ld, Cd0, wd, psi_d):
        g = self.cfg.guidance
        sig_b, sig_r = self.measurement_sigmas()  # converged: from now on the sensor's own noise
        self.nav.bearing_var, self.nav.rate_var = sig_b**2, sig_r**2
        if mode == "approach" and self.cfg.deck.motion == "static":
            self._c0, _ = self._target(Cd0, wd, psi_d, 0.0)
            self.approach = StraightApproach(p_ld - self._c0, g.duration_s, g.k_static)
            self._set_mode(t, "approach", f"manual hold over; straight tau gaps, k={g.k_static}, T={g.duration_s}s")
        elif mode == "hover":
            self._set_mode(t, "hover", "handed over to the autonomy")

    def _maybe_start(self, t, tm, p_ld, Cd0, wd, psi_d):
        g = self.cfg.guidance
        if tm < (g.go_around_hover_s if self._go_arounds else g.hover_min_s):
            return
        rho0 = float(np.linalg.norm(p_ld))
        T = np.sqrt(18.0 * rho0 / g.touchdown_accel_mps2)
        c, n_up = self._target(Cd0, wd, psi_d, T)
        try:
            a_td, lam, gam = touchdown_acceleration(n_up, g.touchdown_accel_mps2)
        except ValueError:
            return
        az = np.arctan2(p_ld[1] - c[1], p_ld[0] - c[0])
        dl = abs((lam - az + np.pi) % (2 * np.pi) - np.pi)
        near = np.linalg.norm(p_ld - self.start_rel_ld) <= g.start_tolerance_m
        ok = (near and dl <= np.radians(g.lambda_max_deg)
              and np.radians(g.gamma_min_deg) <= gam <= np.radians(g.gamma_max_deg))
        relaxed = tm >= g.max_wait_s and gam <= np.radians(g.gamma_max_deg)  # late: any heading, never too flat
        if ok or relaxed:
            self.approach = TauGapApproach(p_ld - c, a_td, g.k_rho, g.k_alpha_beta)
            self._a_td = a_td
            why = "conditions met" if ok else "waited max_wait_s"
            self._set_mode(t, "approach", f"{why}: lambda={np.degrees(lam):.0f} deg, gamma={np.degrees(gam):.0f} deg, "
                                          f"T={self.approach.T:.2f}s")

    # --- the loop ------------------------------------------------------------------------------
    def run(self, progress=None) -> RunResult:
        from visnav.analysis.deck_metrics import deck_metrics

        sc, dt, cfg = self.sc, self.dt, self.cfg
        n = int(round(sc.run.duration_s / dt))
        d_cam = self.frame_steps
        imu_rng, ahrs_rng = self.rng[4], self.rng[5]
        imu = cfg.imu
        cmd = AttitudeThrustCommand(0.0, 0.0, 0.0, 0.0, self.params.hover_throttle)
        self._set_mode(0.0, "manual", "pilot holds the start while the filter starts")
        wall0 = time.perf_counter()
        error = None
        interrupted = False
        t = 0.0
        try:
            for k in range(n + 1):
                t = k * dt
                ds = self.deck.state(t)
                s = self.vehicle.state
                acc = s.specific_force + imu.accel_noise_mps2 * imu_rng.standard_normal(3)
                gyro = s.body_rates + imu.gyro_noise_rad_s * imu_rng.standard_normal(3)
                att = s.euler[:2] + np.radians(imu.attitude_noise_deg) * ahrs_rng.standard_normal(2)
                g_body = euler_to_dcm([att[0], att[1], 0.0]).T @ np.array([0.0, 0.0, G])
                self.nav.imu(t, acc, gyro, g_body)
                if k % d_cam == 0:
                    self._camera(t, ds)
                x_true = self.truth_state(t, ds)
                if k % 2 == 0:
                    acc_up = -(euler_to_dcm([att[0], att[1], 0.0]) @ acc)[2] - G
                    truth_pilot = self.mission.mode == "manual" and cfg.start.pilot == "truth"
                    x_ctrl = x_true if truth_pilot else self.nav.x
                    cmd = self._control(t, x_ctrl, gyro, att[0], att[1], acc_up, 2 * dt)
                self._log(t, x_true, ds, cmd)
                if self._contact(t, ds):
                    break
                gear_h = self._gear_height(ds)
                self.vehicle.step(cmd, dt, rotor_height_m=gear_h + self.params.gear_offset + self.params.rotor_height)
                if progress is not None:
                    progress(t, sc.run.duration_s)
        except Exception as exc:  # noqa: BLE001 - keep what the run has
            error = f"{type(exc).__name__} at t={t:.2f}s: {exc}"
        except KeyboardInterrupt:  # Ctrl-C: stop here and keep what the run has
            interrupted = True
        wall = time.perf_counter() - wall0
        metrics = deck_metrics(self, t, wall, error)
        return RunResult(scenario=sc, log=self.log, metrics=metrics, error=error, interrupted=interrupted)

    def _camera(self, t, ds):
        c = self.cfg.camera
        lights = self.lights
        if c.hide_light >= 0 and t >= c.hide_after_s and c.hide_light < len(lights):
            lights = np.delete(lights, c.hide_light, axis=0)
        s = self.vehicle.state
        to_ned = lambda b: ds.position + b @ ds.C.T  # noqa: E731
        img = self.led_camera.render(s.position, euler_to_dcm(s.euler), to_ned(lights), to_ned(self.deck_corners),
                                     to_ned(self.extra) if len(self.extra) else None)
        uv = find_blobs(img, self.tracker.threshold)
        if c.centroid_noise_px > 0 and len(uv):
            uv = uv + c.centroid_noise_px * self._centroid_rng.standard_normal(uv.shape)
        frame = self.tracker.from_pixels(t, uv)
        used = self.nav.camera(frame.bearings, frame.rates)
        self.log.record("camera", t, blobs=len(frame.bearings), lights_used=used,
                        nis=self.nav.last_nis if used else float("nan"), dof=self.nav.last_dof if used else 0,
                        bearing_rms=self.nav.last_bearing_rms if used else float("nan"))

    def _gear_height(self, ds) -> float:
        """Height of the gear above the deck plane, along the deck normal."""
        return float(-(ds.C[:, 2] @ (self.vehicle.gear_point() - ds.position)))

    def _contact(self, t, ds) -> bool:
        if self._gear_height(ds) > 0.0:
            return False
        s = self.vehicle.state
        gear = self.vehicle.gear_point()
        w_n = ds.C @ ds.body_rates
        v_point = ds.velocity + np.cross(w_n, gear - ds.position)
        rel = s.velocity - v_point
        zb, zd = euler_to_dcm(s.euler)[:, 2], ds.C[:, 2]
        g_d = ds.C.T @ (gear - ds.position)
        pos_err = float(np.hypot(*(g_d[:2] - self.landing_point[:2])))  # from the desired landing location
        on = bool(np.all(np.abs(g_d[:2]) <= self.cfg.deck.size_m / 2))  # on the square plate
        self.touchdown = dict(t=t, rel_speed=float(np.linalg.norm(rel)), pos_err=pos_err, on_deck=on,
                              att_mismatch=float(np.degrees(np.arccos(np.clip(zb @ zd, -1, 1)))))
        self._set_mode(t, "landed" if on else "missed", f"gear contact at {self.touchdown['rel_speed']:.2f} m/s")
        return True

    def _log(self, t, x_true, ds, cmd):
        x, P = self.nav.x, self.nav.covariance()
        err = dm.residual_x(x_true[None, :], x[None, :])[0]
        try:
            nees = float(err @ np.linalg.solve(P, err))
        except np.linalg.LinAlgError:
            nees = float("nan")
        s = self.vehicle.state
        self.log.record("truth", t, position=x_true[0:3], euler=x_true[3:6], velocity=x_true[6:9], deck_rates=x_true[9:12])
        self.log.record("estimate", t, position=x[0:3].copy(), euler=x[3:6].copy(), velocity=x[6:9].copy(),
                        deck_rates=x[9:12].copy(), sigma=np.sqrt(np.maximum(np.diag(P), 0.0)), nees=nees,
                        mode=self.mission.mode)
        self.log.record("vehicle", t, position=s.position.copy(), euler=s.euler.copy(), velocity=s.velocity.copy(),
                        gear_height=self._gear_height(ds))
        self.log.record("deck", t, position=ds.position, euler=ds.euler)
        self.log.record("command", t, roll=cmd.roll, pitch=cmd.pitch, yaw_rate=cmd.yaw_rate, throttle=cmd.throttle)
