"""Analytic trajectories with exact inertial readings (flat, non-rotating Earth, constant g).

Position and Euler angles are sums of sinusoids (plus a constant-velocity term), so velocity,
acceleration and Euler rates are exact derivatives; the ideal accelerometer reads
``f^b = C_n^b (a^n - g^n)`` and the ideal gyro ``w = euler_rates_to_body_rates(euler, euler')``
(seed 002 eq. 3.7 inverted). Used to test the INS and the error-state filter against exact truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from visnav.geometry.rotations import euler_rates_to_body_rates, euler_to_dcm

__all__ = ["SinusoidTrajectory", "manoeuvring_flight", "hover"]


@dataclass(frozen=True)
class SinusoidTrajectory:
    """x(t) = x0 + v0 t + sum_i A_i sin(w_i t + phi_i), per axis, for position and Euler angles."""

    p0: tuple = (0.0, 0.0, -60.0)
    v0: tuple = (0.0, 0.0, 0.0)
    p_amp: tuple = ((0.0, 0.0, 0.0),)  # rows: (N, E, D) amplitudes [m]
    p_freq: tuple = (0.0,)  # [rad/s], one per row
    p_phase: tuple = ((0.0, 0.0, 0.0),)
    e0: tuple = (0.0, 0.0, 0.0)  # roll, pitch, yaw [rad]
    e_amp: tuple = ((0.0, 0.0, 0.0),)
    e_freq: tuple = (0.0,)
    e_phase: tuple = ((0.0, 0.0, 0.0),)
    e_rate: tuple = (0.0, 0.0, 0.0)  # constant Euler-angle rates [rad/s]
    g: float = 9.81

    @staticmethod
    def _eval(t, x0, rate, amp, freq, phase):
        t = np.asarray(t, dtype=float)[:, None, None]
        A = np.asarray(amp, dtype=float)[None]
        w = np.asarray(freq, dtype=float)[None, :, None]
        ph = np.asarray(phase, dtype=float)[None]
        arg = w * t + ph
        x = np.asarray(x0) + np.asarray(rate) * t[:, 0] + (A * np.sin(arg)).sum(1)
        xd = np.asarray(rate) + (A * w * np.cos(arg)).sum(1)
        xdd = (-A * w**2 * np.sin(arg)).sum(1)
        return x, xd, xdd

    def sample(self, t) -> dict[str, np.ndarray]:
        """Truth and ideal IMU at times t (N,): position, velocity, accel_ned, euler,
        euler_rates, dcm (N,3,3), specific_force (body), gyro (body)."""
        p, v, a = self._eval(t, self.p0, self.v0, self.p_amp, self.p_freq, self.p_phase)
        e, ed, _ = self._eval(t, self.e0, self.e_rate, self.e_amp, self.e_freq, self.e_phase)
        C = euler_to_dcm(e)
        g = np.array([0.0, 0.0, self.g])
        f_b = np.einsum("nji,nj->ni", C, a - g)
        w_b = euler_rates_to_body_rates(e, ed)
        return {"t": np.asarray(t, dtype=float), "position": p, "velocity": v, "accel_ned": a,
                "euler": e, "euler_rates": ed, "dcm": C, "specific_force": f_b, "gyro": w_b}


def manoeuvring_flight(yaw0: float = 0.3) -> SinusoidTrajectory:
    """A helicopter-like flight: 8 m/s cruise north-east with lateral S-turns (+-1.5 m/s^2),
    gentle climbs, roll/pitch +-10 deg and heading swings of +-30 deg."""
    return SinusoidTrajectory(
        p0=(0.0, 0.0, -60.0), v0=(6.0, 5.0, 0.0),
        p_amp=((0.0, 40.0, 2.0), (25.0, 0.0, 0.0)), p_freq=(0.2, 0.25),
        p_phase=((0.0, 0.0, 0.5), (0.0, 0.0, 0.0)),
        e0=(0.0, 0.0, yaw0), e_amp=((0.15, 0.1, 0.5),), e_freq=(0.2,), e_phase=((0.3, 1.0, 0.0),),
    )


def hover(euler=(0.0, 0.0, 0.0)) -> SinusoidTrajectory:
    """Stationary at 60 m with a fixed attitude."""
    return SinusoidTrajectory(e0=tuple(euler))
