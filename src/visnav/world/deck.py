"""A moving landing deck: six sinusoidal degrees of freedom (seed 003 eq. 5.11) and its lights.

Each degree of freedom (surge, sway, heave in metres along the deck's nominal heading axes; roll,
pitch, yaw in radians) follows a sum of up to three sinusoids, as the thesis' Stewart platform:

    d(t) = sum_n a_n sin(w_n t + phi_n)                                     (eq. 5.11)

Sea-state presets give, per axis, a nominal amplitude and frequency with their standard
deviations; the same numbers size the filter's process noise (eq. 3.7) and its sea-state
initial covariance (eq. 3.14-3.15). The deck frame is FRD-like: x forward, y starboard, z down,
origin at the landing point; the lights lie in it (eq. 5.10 by default).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from visnav.estimation.deck import SEA_STATES as _SEA_STATES
from visnav.geometry.rotations import cross3, dcm_to_euler, euler_rates_to_body_rates, euler_to_dcm, euler_to_dcm3

#: the four LEDs of eq. 5.10 (deck frame, m)
LEDS_EQ_5_10 = np.array([[-0.128, 0.0, 0.0], [0.0, -0.102, 0.0], [0.0, 0.102, 0.0], [0.058, 0.0, 0.0]])

#: axis order of every (6,) array here
AXES = ("surge", "sway", "heave", "roll", "pitch", "yaw")

#: the sea-state presets (nominal amplitude, frequency and their sigmas per axis) live beside the filter
#: that is tuned from them (``estimation/deck.py``); the world draws its motion around them
SEA_STATES = _SEA_STATES


def validate_lights(lights) -> np.ndarray:
    """A deck light layout (L, 3) in metres; fewer than 3 lights, or repeated / non-finite ones, refused."""
    b = np.asarray(lights, dtype=float)
    if b.ndim != 2 or b.shape[1] != 3:
        raise ValueError(f"deck lights must be a list of [x, y, z] points, got shape {b.shape}")
    if b.shape[0] < 3:
        raise ValueError(f"deck layout has {b.shape[0]} lights; the relative pose needs at least 3")
    if not np.all(np.isfinite(b)):
        raise ValueError("deck light positions must be finite")
    d = np.linalg.norm(b[:, None] - b[None], axis=-1) + np.eye(len(b))
    if np.any(d < 1e-3):
        raise ValueError("two deck lights are closer than 1 mm")
    return b


@dataclass(frozen=True)
class DeckState:
    t: float
    position: np.ndarray  # NED of the deck origin (landing point) [m]
    velocity: np.ndarray  # NED [m/s]
    euler: np.ndarray  # deck attitude (roll, pitch, yaw) [rad]
    body_rates: np.ndarray  # deck body rates (deck frame) [rad/s]
    C: np.ndarray  # C_d^n (deck -> NED)


class DeckMotion:
    """Sum-of-sinusoids motion of eq. 5.11 around a nominal position and heading."""

    def __init__(self, amplitude, omega, phase, position=(0.0, 0.0, 0.0), heading: float = 0.0, tilt=(0.0, 0.0)):
        self.a = np.atleast_2d(np.asarray(amplitude, float))  # (6, N)
        self.w = np.atleast_2d(np.asarray(omega, float))
        self.ph = np.atleast_2d(np.asarray(phase, float))
        if self.a.shape[0] != 6 or self.a.shape != self.w.shape or self.a.shape != self.ph.shape:
            raise ValueError("deck motion needs amplitude, omega and phase arrays of shape (6, N)")
        if self.a.shape[1] > 3:
            raise ValueError("the deck motion takes at most 3 sinusoids per axis (eq. 5.11)")
        self.p0 = np.asarray(position, float)
        self.heading = float(heading)
        self.tilt = tuple(float(v) for v in tilt)  # the mean roll and pitch the motion is about (list, trim) [rad]
        c, s = np.cos(heading), np.sin(heading)
        self._Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    @classmethod
    def static(cls, position=(0.0, 0.0, 0.0), heading: float = 0.0, tilt=(0.0, 0.0)) -> "DeckMotion":
        """A deck at rest, ``tilt`` (roll, pitch) [rad] off level."""
        z = np.zeros((6, 1))
        return cls(z, z, z, position, heading, tilt)

    @classmethod
    def from_sea_state(cls, name: str, rng: np.random.Generator, n_sinusoids: int = 1, scale: float = 1.0,
                       position=(0.0, 0.0, 0.0), heading: float = 0.0, tilt=(0.0, 0.0)) -> "DeckMotion":
        """Draw amplitudes and frequencies around the preset's nominal values, phases uniform; the motion is about
        ``tilt`` (the ship's list and trim, roll and pitch [rad])."""
        if name not in SEA_STATES:
            raise ValueError(f"unknown sea state {name!r}; known: {', '.join(SEA_STATES)}")
        if not 1 <= n_sinusoids <= 3:
            raise ValueError("n_sinusoids must be 1, 2 or 3 (eq. 5.11)")
        A, W, sA, sW = SEA_STATES[name]
        n = n_sinusoids
        amp = np.abs(A[:, None] + sA[:, None] * rng.standard_normal((6, n))) * scale / n
        om = np.abs(W[:, None] + sW[:, None] * rng.standard_normal((6, n)))
        ph = rng.uniform(0.0, 2 * np.pi, (6, n))
        return cls(amp, om, ph, position, heading, tilt)

    def displacement(self, t: float):
        """(d, d_dot) of the six axes at time t (eq. 5.11 and its derivative)."""
        arg = self.w * t + self.ph
        d = (self.a * np.sin(arg)).sum(axis=1)
        dd = (self.a * self.w * np.cos(arg)).sum(axis=1)
        return d, dd

    def state(self, t: float) -> DeckState:
        """The deck at ``t``; the last one is kept (the loop, the camera and the observer ask for the same
        instant), its arrays read-only so that no reader can change what the next one gets."""
        last = getattr(self, "_last", None)
        if last is not None and last.t == t:
            return last
        d, dd = self.displacement(t)
        pos = self.p0 + self._Rz @ d[:3]
        vel = self._Rz @ dd[:3]
        roll, pitch, yaw = d[3:].tolist()
        roll, pitch, yaw = roll + self.tilt[0], pitch + self.tilt[1], self.heading + yaw
        euler = np.array([roll, pitch, yaw])
        rates = np.asarray(euler_rates_to_body_rates(euler, dd[3:]))
        C = euler_to_dcm3(roll, pitch, yaw)  # (euler_to_dcm(euler)'s one-vector path, from the floats)
        for a in (pos, vel, euler, rates, C):
            a.flags.writeable = False
        self._last = DeckState(t=t, position=pos, velocity=vel, euler=euler, body_rates=rates, C=C)
        return self._last


def relative_state(vehicle, ds: DeckState) -> np.ndarray:
    """The 12 relative states of ``estimation/deck.py`` (r, e, v, w_d) from the true vehicle and deck states.

    ``vehicle`` has ``position``, ``velocity``, ``euler`` and ``body_rates`` (a ``VehicleState``).
    """
    Ch = euler_to_dcm(vehicle.euler)
    r = Ch.T @ (ds.position - vehicle.position)
    e = dcm_to_euler(ds.C.T @ Ch)
    v = Ch.T @ (ds.velocity - vehicle.velocity) - cross3(vehicle.body_rates, r)
    return np.concatenate([r, e, v, np.asarray(ds.body_rates, float)])


@dataclass
class DeckWorld:
    """The deck scene the sensors see: its motion, the square plate, the lights and other bright points.

    ``hide_light`` (an index, -1 none) drops one light out of view from ``hide_after_s`` on (a light
    that fails or is occluded).
    """

    motion: DeckMotion
    lights: np.ndarray  # (L, 3) deck frame [m]
    size_m: float
    extra: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # bright non-lights, deck frame
    hide_light: int = -1
    hide_after_s: float = 0.0

    def __post_init__(self):
        self.lights = validate_lights(self.lights)
        self.extra = np.asarray(self.extra, float).reshape(-1, 3)
        h = self.size_m / 2
        self.corners = np.array([[h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0], [-h, h, 0.0]])

    def lights_at(self, t: float) -> np.ndarray:
        """The lights that shine at ``t`` (deck frame)."""
        if 0 <= self.hide_light < len(self.lights) and t >= self.hide_after_s:
            return np.delete(self.lights, self.hide_light, axis=0)
        return self.lights

    def relative(self, vehicle, ds: DeckState) -> np.ndarray:
        """``relative_state(vehicle, ds)``, kept for the last pair of states (one step's motion capture sample
        and truth log ask for the same pair; the states are never changed in place): a fresh copy each call."""
        last = getattr(self, "_relative", None)
        if last is None or last[0] is not vehicle or last[1] is not ds:
            last = self._relative = (vehicle, ds, relative_state(vehicle, ds))
        return last[2].copy()

    @staticmethod
    def to_ned(ds: DeckState, points: np.ndarray) -> np.ndarray:
        return ds.position + np.asarray(points, float) @ ds.C.T
