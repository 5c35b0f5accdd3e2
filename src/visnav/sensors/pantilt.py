"""Pan-tilt unit and the spring-damped camera platform of the WITAS landing camera (seed 002 §6.1-6.3).

``PanTiltUnit``: two position servos (pan about the platform z axis, tilt = depression, as in
``geometry/mounts.PanTiltMount``) with angle limits, a rate limit and a proportional servo gain;
targets come from the tracking controller (the image-processing computer, ``navigation/pad.py``)
through ``point_at``; the state is advanced lazily to any later time (1 ms sub-steps). Encoders
read the angles quantised to ``encoder_resolution``.

``SpringPlatform``: the camera sits on a platform suspended on springs against vibration (§6.3:
"this produces alignment errors"). The platform is rotated against the body by a constant mount
misalignment plus a deflection delta that obeys, per body axis,

    delta'' + 2 zeta w delta' + w^2 delta = -d(omega_body)/dt

(the platform's inertia resists the body's angular acceleration; its springs pull it back). With
y = delta' + omega_body this is  delta' = y - omega,  y' = -w^2 delta - 2 zeta w (y - omega):
driven by the body rate itself, integrated exactly (zero-order hold over 5 ms).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm

from visnav.geometry.mounts import PanTiltMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.sensors.base import TruthAt


class PanTiltUnit:
    def __init__(self, pan: float = 0.0, tilt: float = math.pi / 2, pan_limits=(-math.pi, math.pi),
                 tilt_limits=(math.radians(10.0), math.radians(120.0)), max_rate: float = math.radians(90.0),
                 servo_gain: float = 8.0, encoder_resolution: float = math.radians(0.05), lever_arm=(0.0, 0.0, 0.0),
                 head_offset=(0.0, 0.0, 0.0)):
        self.mount = PanTiltMount(pan, tilt, pan_limits, tilt_limits, lever_arm)
        self.max_rate = float(max_rate)
        self.gain = float(servo_gain)
        self.encoder_resolution = float(encoder_resolution)
        self.head_offset = np.asarray(head_offset, float)  # camera centre from the axes' crossing, camera frame
        self.target = np.array([self.mount.pan, self.mount.tilt])
        self.t = 0.0

    @property
    def angles(self) -> np.ndarray:
        return np.array([self.mount.pan, self.mount.tilt])

    def _axis(self, a: float, target: float, h: float) -> float:
        """Exact servo motion over h: at the rate limit while the error exceeds max_rate / gain,
        then an exponential approach e' = -gain e."""
        e = target - a
        e_lin = self.max_rate / self.gain
        if abs(e) > e_lin:
            t_lin = (abs(e) - e_lin) / self.max_rate
            if h <= t_lin:
                return a + math.copysign(self.max_rate * h, e)
            h -= t_lin
            e = math.copysign(e_lin, e)
        return target - e * math.exp(-self.gain * h)

    def advance(self, t: float) -> None:
        """Move the servos from the last time to ``t`` (no-op for an earlier t)."""
        if t <= self.t:
            return
        h = t - self.t
        a = self.angles
        self.mount.set(self._axis(a[0], self.target[0], h), self._axis(a[1], self.target[1], h))
        self.t = t

    def point_at(self, t: float, pan: float, tilt: float) -> None:
        """New servo targets from ``t`` on (clamped to the limits)."""
        self.advance(t)
        lo_p, hi_p = self.mount.pan_limits
        lo_t, hi_t = self.mount.tilt_limits
        self.target = np.array([min(max(pan, lo_p), hi_p), min(max(tilt, lo_t), hi_t)])

    def encoders(self) -> tuple[float, float]:
        q = self.encoder_resolution
        a = self.angles
        return (float(np.round(a[0] / q) * q), float(np.round(a[1] / q) * q)) if q > 0 else (float(a[0]), float(a[1]))

    def camera_offset_body(self, R_cam_to_body: np.ndarray | None = None) -> np.ndarray:
        """Camera centre in body axes from the vehicle reference point: lever arm + the head offset."""
        R = self.mount.R_cam_to_body if R_cam_to_body is None else R_cam_to_body
        return self.mount.lever_arm + R @ self.head_offset


class SpringPlatform:
    def __init__(self, misalignment_deg=(0.0, 0.0, 0.0), natural_hz: float = 6.0, damping: float = 0.2,
                 step_s: float = 0.005):
        self.misalignment = np.radians(np.asarray(misalignment_deg, float))
        w = 2 * math.pi * float(natural_hz)
        A = np.array([[0.0, 1.0], [-w * w, -2 * damping * w]])  # state (delta, y), input omega
        B = np.array([[-1.0], [2 * damping * w]])
        M = np.zeros((3, 3))
        M[:2, :2], M[:2, 2:] = A * step_s, B * step_s
        E = expm(M)
        self.Phi, self.Gam = E[:2, :2], E[:2, 2]
        self.step = step_s
        self.x = np.zeros((2, 3))  # rows (delta, y), columns body axes
        self.t: float | None = None

    def advance(self, t: float, truth_at: TruthAt) -> None:
        if self.t is None:
            self.t = t
            self.x[1] = truth_at(t).body_rates  # at rest on its springs: y = omega, delta = 0
            return
        while self.t < t - 1e-9:
            omega = truth_at(self.t).body_rates
            self.x = self.Phi @ self.x + np.outer(self.Gam, omega)
            self.t += self.step

    @property
    def deflection(self) -> np.ndarray:
        return self.x[0].copy()

    def rotation(self) -> np.ndarray:
        """Platform -> body rotation (misalignment and deflection, small-angle roll-pitch-yaw)."""
        return euler_to_dcm(self.misalignment + self.x[0])
