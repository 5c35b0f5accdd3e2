"""The deck lander's controller (seed 003 §4.2-4.3): reference -> attitude and thrust command.

``DeckController.command(t, estimate, reference)`` takes the deck navigator's estimate (12 relative
states, newest gyro, specific force, roll and pitch) and a ``DeckReference`` from the deck mission:

* ``level`` - hover level on the IMU: roll and pitch 0, no heading rate, thrust from the
  vertical-acceleration PI alone (before the hand-over with ``start.pilot = "imu"``);
* ``follow`` - the spring-damper follower of eq. 4.25-4.27 (``control/multirotor.follow``) on the
  reference position, velocity and feed-forward acceleration (level-deck frame);
* ``descend`` - thrust along the predicted deck normal with the vertical speed servoed to
  ``final_descent_mps`` (or the mission's ``vertical_accel``) and, with ``descent_hold``, the spring-damper
  on the horizontal error.

With ``reference.flare_time_left`` set the last ``flare_s`` before contact turn the commanded
specific force onto the deck normal (:func:`flare`). Then eq. 4.28 (``attitude_command``) and the
throttle law of eq. 4.32-4.33; the heading turns the camera towards the deck. With
``reference.pilot_view`` (the safety pilot, ``start.pilot = "truth"``) the loop closes on what the
pilot sees instead of the estimate.
"""

from __future__ import annotations

import numpy as np

from visnav.control.multirotor import ThrottleController, attitude_command, follow
from visnav.geometry.rotations import euler_to_dcm3
from visnav.guidance.deck_approach import level_deck_geometry, rot_z
from visnav.measurements import AttitudeThrustCommand, DeckReference
from visnav.scalar import clip as _clip

G = 9.81


def flare(a_cmd_ld: np.ndarray, n_up: np.ndarray, t_go: float, flare_s: float,
          max_tilt: float = np.pi / 2) -> np.ndarray:
    """Attitude-matching flare: over the last ``flare_s`` before contact turn the thrust onto the deck normal.

    The feedback of eq. 4.25 tilts the thrust off the planned terminal acceleration (a_td along the
    predicted normal, eq. 4.1-4.3) to correct position and velocity errors; in the last fraction of a
    second attitude matters more than those errors, so the commanded specific force is blended, linearly
    in time, into one along ``n_up`` with the same vertical component (the vertical channel is kept).
    A normal tilted beyond ``max_tilt`` [rad] is taken at ``max_tilt`` (same azimuth): the steepest deck the
    approach can match (``touchdown_acceleration``: asin(a_td / g)); a steeper prediction is the estimate's
    error, and following it swept the vehicle across the deck (moving frozen-camera seed 4: the relative pitch
    29 deg off at contact, 1.13 m/s forward).
    """
    w = _clip(1.0 - t_go / flare_s, 0.0, 1.0)
    if w <= 0.0 or n_up[2] > -0.5:
        return a_cmd_ld
    h = float(np.hypot(n_up[0], n_up[1]))
    if h > np.sin(max_tilt) * float(np.linalg.norm(n_up)):
        s = np.sin(max_tilt)
        n_up = np.array([n_up[0] / h * s, n_up[1] / h * s, -np.cos(max_tilt)])
    f = a_cmd_ld - np.array([0.0, 0.0, G])  # specific force, level-deck frame (z down: f[2] < 0)
    matched = n_up * (f[2] / n_up[2]) + np.array([0.0, 0.0, G])
    return (1.0 - w) * a_cmd_ld + w * matched


class DeckController:
    """Runs at ``rate_hz``; ``guidance`` is the mission's ``DeckGuidanceConfig`` (descent, flare), ``gains`` the
    scenario's ``control.deck`` (the eq. 4.25 spring-damper)."""

    def __init__(self, guidance, gains, max_tilt_deg: float, gear_offset: float, overshoot: float,
                 hover_throttle_1m: float, hover_throttle_ground: float, rate_hz: float, recorder=None):
        self.g, self.gains = guidance, gains
        self.max_tilt = np.radians(max_tilt_deg)
        self.gear_offset, self.overshoot = gear_offset, overshoot
        self.rate_hz = rate_hz
        self.period = 1.0 / rate_hz
        self.throttle = ThrottleController(hover_throttle_1m=hover_throttle_1m,
                                           hover_throttle_ground=hover_throttle_ground)
        self.recorder = recorder

    def _record(self, t, **kw):
        if self.recorder is not None:
            self.recorder("reference", t, **kw)

    def command(self, t: float, est, ref: DeckReference) -> AttitudeThrustCommand:
        g, dt = self.g, self.period
        roll, pitch, gyro = est.roll, est.pitch, est.gyro
        # the vertical specific-force reading, level frame, up positive, gravity removed
        acc_up = -(euler_to_dcm3(float(roll), float(pitch), 0.0) @ est.accel)[2] - G  # (euler_to_dcm's one-vector path)
        tilt_cos = np.cos(roll) * np.cos(pitch)
        if ref.kind == "level":  # (ref.accel: a vertical acceleration to hold, z down; zero by default)
            # on the IMU alone: the navigator's accelerometer-bias estimate taken off (issue 30)
            acc_up = -(euler_to_dcm3(float(roll), float(pitch), 0.0) @ (est.accel - est.accel_bias))[2] - G
            thr = self.throttle.command(-float(ref.accel[2]), acc_up, 1.0, tilt_cos, dt)
            self._record(t, position=np.full(3, np.nan), velocity=np.zeros(3), accel=np.zeros(3))
            return AttitudeThrustCommand(t=t, roll=0.0, pitch=0.0, yaw_rate=0.0, throttle=thr)
        x = ref.pilot_view if ref.pilot_view is not None else est.state
        p, vel, _, psi_d, _ = level_deck_geometry(x, gyro, roll, pitch)
        Rz = rot_z(psi_d)
        p_ld, v_ld = Rz.T @ p, Rz.T @ vel
        if ref.kind == "descend":  # thrust along the deck normal (attitude matched), sink at final_descent_mps
            c, n_up = ref.target, ref.normal
            p_des, v_des = np.array([c[0], c[1], p_ld[2]]), np.array([0.0, 0.0, g.final_descent_mps])
            a_z = self.gains.damper_per_s * (g.final_descent_mps - v_ld[2])
            if ref.vertical_accel is not None:  # the mission sinks on the IMU (a blind end, no fix to trust)
                a_z = float(ref.vertical_accel)
            a_ff = np.array([0.0, 0.0, G]) + (G - a_z) / max(-n_up[2], 0.5) * n_up
            fb = follow(p_des, np.zeros(3), np.zeros(3), p_ld, v_ld, self.gains.spring_per_s2, self.gains.damper_per_s)
            a_cmd_ld = a_ff + (np.array([fb[0], fb[1], 0.0]) if g.descent_hold else 0.0)
        elif ref.kind == "follow":
            p_des, v_des = ref.position, ref.velocity
            a_cmd_ld = follow(p_des, v_des, ref.accel, p_ld, v_ld, self.gains.spring_per_s2, self.gains.damper_per_s)
            if ref.vertical_accel is not None:  # the mission holds the height on the IMU (hover without a fix)
                a_cmd_ld = np.array([a_cmd_ld[0], a_cmd_ld[1], float(ref.vertical_accel)])
        else:
            raise ValueError(f"unknown deck reference kind {ref.kind!r} (level, follow, descend)")
        if ref.flare_time_left is not None and g.flare_s > 0:
            # time to contact: gear height over the predicted deck plane / closing speed along its normal
            c, n_up = ref.target, ref.normal
            h = float(n_up @ (p_ld - c)) - self.overshoot  # c: the body at contact, overshoot below
            closing = float(-(n_up @ v_ld))
            t_c = min(h / closing if closing > 1e-3 else np.inf, ref.flare_time_left)
            a_cmd_ld = flare(a_cmd_ld, n_up, t_c, g.flare_s, np.arcsin(min(g.touchdown_accel_mps2 / G, 1.0)))
        a_cmd = Rz @ a_cmd_ld
        _, phi, theta = attitude_command(a_cmd, self.max_tilt)
        height = max(-p_ld[2] - self.gear_offset, 0.0)
        thr = self.throttle.command(-a_cmd[2], acc_up, height, tilt_cos, dt)
        r = x[0:3]
        yaw_rate = 1.0 * np.arctan2(r[1], r[0]) if np.hypot(r[0], r[1]) > 0.3 else 0.0
        self._record(t, position=Rz @ p_des, velocity=Rz @ v_des, accel=a_cmd)
        return AttitudeThrustCommand(t=t, roll=phi, pitch=theta, yaw_rate=float(yaw_rate), throttle=thr)
