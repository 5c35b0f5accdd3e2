"""Barometric altimeter and compass of the WITAS R-MAX (seed 002 §5.8.4: 'the differential barometric
altitude ... between the take-off and the current flight position'; §5.9.1: a compass for heading).

Baro: altitude = -down + bias(t) + white noise, the bias a first-order Gauss-Markov drift (weather,
ground effect). With ``c0`` / ``c1`` set it is also CONDOR's barometer (seed 004 eq. 2.1): the raw
reading is the eq. 2.1 inverse of the true height at the true outside temperature ``t_outside_c``,
which the navigator corrects with the temperature it measured (``vision/rectification.altimeter_correction``).
The one barometer model of the project. Compass: heading + constant bias + white noise.
"""

from __future__ import annotations

import math

import numpy as np

from visnav.measurements import BaroSample, HeadingSample
from visnav.sensors.base import TruthAt


class Baro:
    def __init__(self, rng: np.random.Generator, rate_hz: float = 20.0, sigma_m: float = 0.3,
                 bias_sigma_m: float = 0.5, bias_tau_s: float = 300.0, latency_s: float = 0.0,
                 t_outside_c: float = 15.0, c0: float = 0.0, c1: float = 0.0):
        self.rng = rng
        self.rate_hz = rate_hz
        self.sigma = sigma_m
        self.latency_s = latency_s
        self.bias_sigma = bias_sigma_m
        self.tau = bias_tau_s
        self.bias = rng.normal(0.0, bias_sigma_m) if bias_sigma_m > 0 else 0.0
        self.k = c0 + (15.0 - t_outside_c) * c1  # eq. 2.1: h = raw (1 - k raw)
        self._t = None

    def raw(self, h_true: float) -> float:
        """The eq. 2.1 inverse: what the sensor reads at true height ``h_true`` (``h_true`` itself when k = 0)."""
        k = self.k
        if k <= 0:
            return h_true
        h = max(float(h_true), 0.0)
        disc = 1.0 - 4.0 * k * h
        return (1.0 - math.sqrt(disc)) / (2.0 * k) if disc > 0 else 1.0 / (2.0 * k)

    def sample(self, t: float, truth_at: TruthAt, world=None) -> BaroSample:
        if self._t is not None and self.bias_sigma > 0:
            a = math.exp(-(t - self._t) / self.tau)
            self.bias = a * self.bias + self.bias_sigma * math.sqrt(1 - a * a) * self.rng.standard_normal()
        self._t = t
        s = truth_at(t)
        return BaroSample(t=t, altitude=float(self.raw(-s.position[2]) + self.bias + self.sigma * self.rng.standard_normal()))


def baro_sensor(cfg, rng: np.random.Generator) -> Baro:
    """The ``Baro`` of a scenario's ``[sensors.baro]`` (``scenarios/config_sensors.BaroConfig``)."""
    return Baro(rng, cfg.rate_hz, cfg.sigma_m, cfg.bias_sigma_m, cfg.bias_tau_s, t_outside_c=cfg.t_outside_c,
                c0=cfg.c0, c1=cfg.c1)


class Compass:
    def __init__(self, rng: np.random.Generator, rate_hz: float = 10.0, sigma_deg: float = 1.0,
                 bias_deg: float = 0.5, latency_s: float = 0.0):
        self.rng = rng
        self.rate_hz = rate_hz
        self.sigma = math.radians(sigma_deg)
        self.bias = math.radians(rng.normal(0.0, bias_deg)) if bias_deg > 0 else 0.0
        self.latency_s = latency_s

    def sample(self, t: float, truth_at: TruthAt, world=None) -> HeadingSample:
        s = truth_at(t)
        h = float(s.euler[2]) + self.bias + self.sigma * self.rng.standard_normal()
        return HeadingSample(t=t, heading=(h + math.pi) % (2 * math.pi) - math.pi)
