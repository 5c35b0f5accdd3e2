"""A rigid-body multirotor (Y6 hexacopter preset) behind an attitude + thrust autopilot (seed 003 §2.2.2, §5.1).

The thesis' vehicle is a Y6 whose Pixhawk tracks commanded roll, pitch, yaw rate and throttle;
the Odroid closes the outer loops. Modelled here:

* roll and pitch follow their commands as second-order systems of finite bandwidth
  (natural frequency ``attitude_omega``, damping ``attitude_zeta``), yaw rate as a first-order lag;
* thrust along body -z follows ``throttle * max_thrust`` through a first-order lag, multiplied by
  the ground-effect factor of Cheeseman and Bennett, ``1 / (1 - (R / 4 z)^2)`` (z the rotor height
  above the surface below, capped);
* translation: m a = m g + C_b^n [0, 0, -T] - m c_d (v - v_wind) (linear drag); the landing gear is
  ``gear_offset`` below the body origin along body z.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from visnav.geometry.rotations import euler_rates_to_body_rates, euler_to_dcm
from visnav.measurements import AttitudeThrustCommand  # noqa: F401 - the command type lives in measurements.py
from visnav.vehicles.base import Environment

G = 9.81


@dataclass(frozen=True)
class MultirotorParams:
    mass: float = 2.4  # kg (3DR Y6 with Odroid and camera)
    thrust_to_weight: float = 2.0
    attitude_omega: float = 12.0  # rad/s
    attitude_zeta: float = 0.8
    yaw_rate_tau: float = 0.15  # s
    thrust_tau: float = 0.04  # s
    drag: float = 0.3  # 1/s
    rotor_radius: float = 0.127  # m (10 in propellers)
    rotor_height: float = 0.05  # rotor plane above the body origin [m]
    gear_offset: float = 0.17  # landing gear below the body origin [m] (§5.3.3)

    @property
    def max_thrust(self) -> float:
        return self.thrust_to_weight * self.mass * G

    @property
    def hover_throttle(self) -> float:
        return 1.0 / self.thrust_to_weight

    def ground_effect(self, rotor_height_m: float) -> float:
        """Thrust ratio in / out of ground effect (Cheeseman-Bennett), capped at 1.3."""
        z = max(rotor_height_m, 1e-3)
        q = (self.rotor_radius / (4.0 * z)) ** 2
        return float(min(1.0 / (1.0 - min(q, 0.9)), 1.3))


@dataclass
class MultirotorState:
    position: np.ndarray
    velocity: np.ndarray
    euler: np.ndarray
    euler_rate: np.ndarray
    thrust: float
    specific_force: np.ndarray
    body_rates: np.ndarray


class Multirotor:
    def __init__(self, params: MultirotorParams, position, yaw: float = 0.0, velocity=(0.0, 0.0, 0.0)):
        self.p = params
        T0 = params.mass * G
        self.state = MultirotorState(position=np.array(position, float), velocity=np.array(velocity, float),
                                     euler=np.array([0.0, 0.0, yaw]), euler_rate=np.zeros(3), thrust=T0,
                                     specific_force=np.array([0.0, 0.0, -G]), body_rates=np.zeros(3))

    def step(self, cmd: AttitudeThrustCommand, dt: float, environment: Environment | None = None) -> MultirotorState:
        """One step of ``dt`` under ``cmd``; ``environment.rotor_height_m`` sets the ground effect, the linear
        drag acts on the velocity relative to ``environment.wind_ned``."""
        env = environment or Environment()
        rotor_height_m, wind = env.rotor_height_m, np.asarray(env.wind_ned, float)
        p, s = self.p, self.state
        # roll and pitch: second order of natural frequency wn and damping zeta toward the command (semi-implicit
        # Euler: the rate first, then the angle with the new rate); yaw rate: first-order lag
        wn, zeta = p.attitude_omega, p.attitude_zeta
        phi, theta, psi = s.euler.tolist()
        phi_d, theta_d, psi_d = s.euler_rate.tolist()
        phi_d += (wn * wn * (cmd.roll - phi) - 2.0 * zeta * wn * phi_d) * dt
        theta_d += (wn * wn * (cmd.pitch - theta) - 2.0 * zeta * wn * theta_d) * dt
        psi_d += (cmd.yaw_rate - psi_d) * min(dt / p.yaw_rate_tau, 1.0)
        ed = np.array([phi_d, theta_d, psi_d])
        e = s.euler + ed * dt
        # thrust: first-order lag to throttle * max thrust in ground effect
        T_cmd = min(max(float(cmd.throttle), 0.0), 1.0) * p.max_thrust * p.ground_effect(rotor_height_m)
        thrust = s.thrust + (T_cmd - s.thrust) * min(dt / p.thrust_tau, 1.0)
        # translation: a = C_b^n [0, 0, -T/m] - c_d (v - v_wind) + g, trapezoidal position
        C = euler_to_dcm(e)
        f_n = -thrust / p.mass * C[:, 2] - p.drag * (s.velocity - wind)  # specific force, NED (thrust along body -z)
        vel = s.velocity + (f_n + np.array([0.0, 0.0, G])) * dt
        pos = s.position + (s.velocity + vel) * 0.5 * dt
        self.state = MultirotorState(position=pos, velocity=vel, euler=e, euler_rate=ed, thrust=thrust,
                                     specific_force=C.T @ f_n, body_rates=np.asarray(euler_rates_to_body_rates(e, ed)))
        return self.state

    def gear_point(self) -> np.ndarray:
        """NED position of the landing gear (``gear_offset`` below the body origin along body z)."""
        s = self.state
        cached = getattr(self, "_gear", None)
        if cached is None or cached[0] is not s:  # once per state (the loop asks several times a step)
            C = euler_to_dcm(s.euler)
            cached = self._gear = (s, s.position + C @ np.array([0.0, 0.0, self.p.gear_offset]))
        return cached[1].copy()
