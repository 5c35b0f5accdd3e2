"""Autopilot telemetry of a small MAV (seed 002 §7.4.2: MP2028g, 4 Hz u-blox GPS, pressure altimeter,
state sent at 5 Hz; the compass was not used, the heading comes from the GPS).

* GPS position: fixes at ``gps_rate_hz`` (the 4 Hz u-blox), each held until the next one (the 5 Hz
  state carries the last fix: up to 0.25 s old), describing the truth ``gps_delay_s`` before the fix
  (the receiver's unknown latency), plus a slowly varying bias (first-order Gauss-Markov of
  ``bias_m`` per axis, ``bias_tau_s``) and white noise (one draw per fix);
* ``downlink()``: what the image processing computer receives, stamped on arrival ``link_delay_s``
  after the autopilot formed it (868 MHz modem, the ground control computer, Ethernet, §7.4 Fig. 7.5);
  the thesis pairs frames with "corresponding telemetry" recorded at the same time and names the
  synchronisation of video and flight data as a problem of the pose-based methods (§7.1), so this
  offset is unknown to the ground station. The autopilot itself flies on ``sample()`` (no link);
* heading: the course over ground of the GPS velocity (velocity noise ``vel_sigma_mps`` with 1 s
  correlation), so it differs from the aircraft's yaw by the crab angle in wind and grows noisy at
  low ground speed; ``extra_heading_deg`` adds a uniform error in +-that to the downlinked heading
  (the Hough campaign);
* barometric height: the take-off reference drifts (a constant ``baro_bias_m`` draw per flight) plus
  white noise.
"""

from __future__ import annotations

import math

import numpy as np

from visnav.measurements import TelemetrySample


class AutopilotTelemetry:
    def __init__(self, rng: np.random.Generator, rate_hz: float = 5.0, gps_sigma_m: float = 0.7,
                 bias_m: float = 3.0, bias_tau_s: float = 600.0, gps_delay_s: float = 0.2,
                 vel_sigma_mps: float = 0.3, baro_bias_m: float = 2.0, baro_noise_m: float = 0.3,
                 extra_heading_deg: float = 0.0, gps_rate_hz: float = 0.0, link_delay_s: float = 0.0) -> None:
        self.rng, self.rate_hz = rng, float(rate_hz)
        self.gps_rate, self.link = float(gps_rate_hz), float(link_delay_s)
        self._fix: tuple[float, np.ndarray, np.ndarray] | None = None  # (fix time, position, velocity)
        self.sigma, self.bias_sigma, self.tau = gps_sigma_m, bias_m, bias_tau_s
        self.delay = float(gps_delay_s)
        self.vsigma = vel_sigma_mps
        self.bias = rng.normal(0.0, bias_m, 2)
        self.vel_err = rng.normal(0.0, vel_sigma_mps, 2)
        self.baro_bias = float(rng.normal(0.0, baro_bias_m))
        self.baro_noise = baro_noise_m
        self.extra = math.radians(extra_heading_deg)
        self._last_t: float | None = None

    def sample(self, t: float, truth_at) -> TelemetrySample:
        """``truth_at(t)`` -> VehicleState (truth enters here only)."""
        dt = 1.0 / self.rate_hz if self._last_t is None else t - self._last_t
        self._last_t = t
        a = math.exp(-dt / self.tau)
        self.bias = a * self.bias + self.bias_sigma * math.sqrt(1 - a * a) * self.rng.standard_normal(2)
        b = math.exp(-dt / 1.0)
        self.vel_err = b * self.vel_err + self.vsigma * math.sqrt(1 - b * b) * self.rng.standard_normal(2)
        ta = t
        tf = math.floor(ta * self.gps_rate + 1e-9) / self.gps_rate if self.gps_rate > 0 else ta  # last GPS fix
        if self._fix is None or tf != self._fix[0]:
            s = truth_at(tf - self.delay)
            pos = s.position.copy()
            pos[:2] += self.rng.normal(0.0, self.sigma, 2)
            self._fix = (tf, pos, s.velocity[:2] + self.vel_err)
        pos = self._fix[1].copy()
        pos[:2] += self.bias
        vel = self._fix[2]
        heading = math.atan2(vel[1], vel[0])
        h = -float(truth_at(ta).position[2]) + self.baro_bias + float(self.rng.normal(0.0, self.baro_noise))
        return TelemetrySample(t=t, position=pos, heading=(heading + math.pi) % (2 * math.pi) - math.pi,
                               height=h, ground_speed=float(np.hypot(*vel)))

    def downlink(self, s: TelemetrySample) -> TelemetrySample:
        """What the ground station receives: the autopilot's sample stamped on its arrival
        (``s.t + link_delay_s``), with ``extra_heading_deg`` of uniform heading error when set (the
        autopilot itself flies on the undisturbed one). It is handed over at once: the navigator
        processes a frame only once a sample stamped after it is in, so only the stamp matters."""
        h = s.heading + (self.rng.uniform(-self.extra, self.extra) if self.extra > 0 else 0.0)
        if self.extra <= 0 and self.link <= 0:
            return s
        return TelemetrySample(s.t + self.link, s.position, (h + math.pi) % (2 * math.pi) - math.pi, s.height,
                               s.ground_speed)
