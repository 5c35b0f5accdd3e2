"""YACS-augmented Yamaha RMAX model (seed 002 §3.5).

Attitude, yaw rate and heave come from the identified YACS + helicopter transfer functions
(seed 002 eq. 3.4, rebuilt from the garbled text):

    φ/ail  = 2.3 (s² + 3.87 s + 53.3) / ((s² + 6.29 s + 16.2)(s² + 8.97 s + 168))   [deg / unit]
    θ/ele  = 0.5 (s² + 9.76 s + 75.5) / ((s² + 3 s + 5.55)(s² + 2.06 s + 123.5))    [deg / unit]
    r/rud  = 9.7 (s + 12.25) / ((s + 4.17)(s² + 3.5 s + 213.4))                    [deg/s / unit]
    aZ/thr = 0.0828 s (s + 3.37) / ((s + 0.95)(s² + 13.1 s + 214.1))                [g / unit]

p, q and ψ follow from the Euler kinematics (eq. 3.7) and the translation from eq. 3.9 with the
thrust of eq. 3.10, T = −g − g·ΔaZ (positive thr = up). Drag acts on the air-relative body
velocity. The hover roll of 4.5 deg that balances the tail rotor is not modelled (seed 002 §3.5.2).

Heave note: aZ/thr = s H(s) has a zero at s = 0: the YACS holds a climb rate, and the identified
response already includes the vehicle's own heave damping. By default (``heave_damping="yacs"``)
Zw damps the departure from the YACS-held climb velocity -g H(s) thr, so a held thr climbs at
g H(0) m/s per unit and disturbances (updrafts, tilt) give bounded velocity errors. With ``heave_damping="full"`` (eq. 3.9 literally) the climb rate is ḣ/thr = g s H(s)/(s − Zw):
zero in steady state, and a thr step moves the height by g H(0)/(−Zw) m per unit
(``heave_height_gain``) — the +-500 range could not descend a 30 m approach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import signal

from visnav.geometry.rotations import cross3, euler_to_dcm3
from visnav.measurements import VehicleState, YacsCommand
from visnav.vehicles.base import Environment
from visnav.vehicles.kernels import rmax_derivatives, rmax_rk4

#: channel -> (numerator, denominator), highest power first; units in the module docstring.
RMAX_TRANSFER_FUNCTIONS: dict[str, tuple[np.ndarray, np.ndarray]] = {
    "roll": (2.3 * np.array([1.0, 3.87, 53.3]), np.polymul([1.0, 6.29, 16.2], [1.0, 8.97, 168.0])),
    "pitch": (0.5 * np.array([1.0, 9.76, 75.5]), np.polymul([1.0, 3.0, 5.55], [1.0, 2.06, 123.5])),
    "yaw_rate": (9.7 * np.array([1.0, 12.25]), np.polymul([1.0, 4.17], [1.0, 3.5, 213.4])),
    "heave": (0.0828 * np.polymul([1.0, 0.0], [1.0, 3.37]), np.polymul([1.0, 0.95], [1.0, 13.1, 214.1])),
}
#: the YACS input that drives each channel
CHANNEL_INPUTS: dict[str, str] = {"roll": "ail", "pitch": "ele", "yaw_rate": "rud", "heave": "thr"}
_CHANNELS = ("roll", "pitch", "yaw_rate", "heave")


def dc_gain(channel: str) -> float:
    """Steady-state gain of one eq. 3.4 channel (0 for heave, which has a zero at s = 0)."""
    num, den = RMAX_TRANSFER_FUNCTIONS[channel]
    return float(num[-1] / den[-1])


def heave_height_gain(zw: float = -0.6, g: float = 9.81) -> float:
    """Height change per unit of a held thr step [m/unit]: g H(0)/(−Zw) (eq. 3.4, 3.9, 3.10)."""
    if not zw < 0:
        raise ValueError(f"zw must be negative, got {zw}")
    num, den = RMAX_TRANSFER_FUNCTIONS["heave"]
    h0 = num[-2] / den[-1]  # aZ = s H(s) thr, H(0) = coefficient of s over the constant term
    return float(g * h0 / -zw)


@dataclass(frozen=True)
class ChannelModel:
    """One eq. 3.4 channel: continuous (A, B, C) and its zero-order-hold discretisation at ``dt``."""

    name: str
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    Ad: np.ndarray
    Bd: np.ndarray
    dt: float


def rmax_state_space(dt: float) -> dict[str, ChannelModel]:
    """The four eq. 3.4 channels as continuous and ZOH-discrete state space (inputs in YACS units)."""
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite number of seconds, got {dt}")
    out = {}
    for name in _CHANNELS:
        A, B, C, D = signal.tf2ss(*RMAX_TRANSFER_FUNCTIONS[name])
        Ad, Bd, _, _, _ = signal.cont2discrete((A, B, C, D), dt, method="zoh")
        out[name] = ChannelModel(name, A, B, C, Ad, Bd, float(dt))
    return out


def _block_diag_model(dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """All four channels stacked: x+ = Ad x + Bd u, y = C x, ẏ = CA x (u = ail, ele, rud, thr)."""
    ch = rmax_state_space(dt)
    n = [ch[c].A.shape[0] for c in _CHANNELS]
    N = sum(n)
    Ad, Bd = np.zeros((N, N)), np.zeros((N, 4))
    C, CA = np.zeros((4, N)), np.zeros((4, N))
    i = 0
    for k, c in enumerate(_CHANNELS):
        m = ch[c]
        s = slice(i, i + n[k])
        Ad[s, s], Bd[s, k] = m.Ad, m.Bd[:, 0]
        C[k, s], CA[k, s] = m.C[0], (m.C @ m.A)[0]
        i += n[k]
    return Ad, Bd, C, CA


_DISCRETISED: dict[float, tuple[np.ndarray, ...]] = {}


def _discretised(dt: float) -> tuple[np.ndarray, ...]:
    """(Ad, Bd, C, CA) at ``dt`` and (Ad, Bd) at ``dt / 2``, computed once per step size in the process
    (a campaign worker builds a model per run) and shared read-only by every model."""
    m = _DISCRETISED.get(dt)
    if m is None:
        Ad, Bd, C, CA = _block_diag_model(dt)
        Ah, Bh, _, _ = _block_diag_model(dt / 2)
        m = (Ad, Bd, C, CA, Ah, Bh)
        for a in m:
            a.setflags(write=False)
        if len(_DISCRETISED) > 64:
            _DISCRETISED.clear()
        _DISCRETISED[dt] = m
    return m


@dataclass
class RmaxParams:
    """Parameters of eq. 3.9-3.10. ``trim`` is the absolute YACS input at trim (ail, ele, rud, thr):
    the commands are increments from it and trim + increment is saturated at ±``input_limit``."""

    Xu: float = -0.025
    Yv: float = -0.1
    Zw: float = -0.6
    g: float = 9.81
    input_limit: float = 500.0
    mass_kg: float = 94.0  # recorded only; eq. 3.9 is per unit mass
    trim: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    #: "yacs": the flight-identified aZ/thr (eq. 3.4) is the YACS' closed-loop heave response, which
    #: holds a climb velocity w_yacs = -g * integral(aZ) (a held thr climbs at g H(0) = 0.0135 m/s per
    #: unit, 6.7 m/s at full stick); Zw damps the departure from it: Zw (w - w_yacs - w_wind). In
    #: still air w = w_yacs exactly; an updraft or a tilt's lift loss gives a bounded velocity error.
    #: "full": eq. 3.9 literally, Zw (w - w_wind): the damping is counted twice, a held thr only
    #: shifts the height by g H(0)/(-Zw) = 0.022 m per unit and +-500 cannot descend more than 11 m.
    heave_damping: str = "yacs"

    def __post_init__(self) -> None:
        for name in ("Xu", "Yv", "Zw"):
            if not getattr(self, name) < 0:
                raise ValueError(f"{name} must be negative (drag), got {getattr(self, name)}")
        if not self.g > 0:
            raise ValueError(f"g must be positive, got {self.g}")
        if self.heave_damping not in ("yacs", "full"):
            raise ValueError(f"heave_damping must be 'yacs' or 'full', got {self.heave_damping!r}")
        if not self.input_limit > 0:
            raise ValueError(f"input_limit must be positive, got {self.input_limit}")
        if len(self.trim) != 4 or any(abs(x) >= self.input_limit for x in self.trim):
            raise ValueError(f"trim must be 4 values inside ±input_limit, got {self.trim}")


def _psi_rate(att: tuple) -> float:
    """ψ̇ = (q sinφ + r cosφ)/cosθ (eq. 3.7)."""
    phi, theta, _, q, r, _ = att
    return (q * math.sin(phi) + r * math.cos(phi)) / math.cos(theta)


class RmaxModel:
    """The augmented RMAX of seed 002 §3.5; ``step`` advances by dt and returns the new truth.

    The four eq. 3.4 channels run as ZOH-discrete state space (exact for a command held over the
    step, also at the RK4 mid-point); u, v, w, N, E, D, ψ are integrated by RK4. The state position
    is the skid reference point and the ground is the plane z = 0 (NED): a descending vehicle that
    reaches it stops (``on_ground``, ``touchdown_speed`` = vertical speed at the last touchdown
    [m/s], NaN before any) and lifts off when the net force points up again.
    ``last_input`` holds the saturated increments (ail, ele, rud, thr) of the last step.
    """

    def __init__(self, params: RmaxParams | None = None, dt: float = 0.01,
                 initial: VehicleState | None = None, *, position: ArrayLike = (0.0, 0.0, 0.0),
                 yaw: float = 0.0, t0: float = 0.0) -> None:
        self.params = params if params is not None else RmaxParams()
        #: step through ``vehicles/kernels.rmax_rk4`` (eq. 3.9 compiled where numba is installed, on floats otherwise;
        #: held to ``_deriv`` at 1e-12 by the tests);
        #: False: the readable RK4 on ``_deriv``
        self.kernel = True
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive finite number of seconds, got {dt}")
        self.dt = float(dt)
        self._cache: dict[float, tuple[np.ndarray, ...]] = {}
        _, _, self._C, self._CA, _, _ = self._matrices(self.dt)
        self._CCA = np.vstack([self._C, self._CA])
        self._X3 = np.empty((self._C.shape[1], 3))
        self._x = np.zeros(self._C.shape[1])
        if initial is not None:
            if np.any(np.abs(initial.euler[:2]) > 1e-12) or np.any(np.abs(initial.body_rates) > 1e-12):
                raise ValueError("initial: RmaxModel starts trimmed; roll, pitch and body_rates must be 0, "
                                 f"got euler={initial.euler}, body_rates={initial.body_rates}")
            pos, yaw, t0 = np.asarray(initial.position, float), float(initial.euler[2]), initial.t
            vel_ned = np.asarray(initial.velocity, float)
        else:
            pos, vel_ned = np.asarray(position, float), np.zeros(3)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)) or pos[2] > 0:
            raise ValueError(f"position must be 3 finite NED values with z <= 0 (ground), got {pos}")
        cb = euler_to_dcm3(0.0, 0.0, yaw)
        w0 = (cb.T @ vel_ned)[2]
        # u v w N E D psi, and w_yacs: the climb velocity the YACS holds, -g * integral of aZ
        self._y = np.concatenate([cb.T @ vel_ned, pos, [yaw, w0]])
        self.last_input = np.zeros(4)
        self.t = float(t0)
        self.on_ground = bool(pos[2] == 0.0)
        if self.on_ground:
            self._y[0:3] = 0.0
        self.touchdown_speed = float("nan")
        self.state = self._make_state(np.zeros(3))

    # -- transfer-function part ------------------------------------------------------------------
    def _matrices(self, dt: float) -> tuple[np.ndarray, ...]:
        key = round(dt, 12)
        if key not in self._cache:
            self._cache[key] = _discretised(dt)
        return self._cache[key]

    def _attitudes(self, *xs: np.ndarray) -> list[tuple]:
        """``_attitude`` of several TF states with one matrix product."""
        X = self._X3 if len(xs) == 3 else np.empty((len(xs[0]), len(xs)))
        for k, x in enumerate(xs):
            X[:, k] = x
        Y = (self._CCA @ X).tolist()  # rows: φ θ r aZ, then their rates; one column per state
        return [self._attitude_from((Y[0][k], Y[1][k], Y[2][k], Y[3][k]), (Y[4][k], Y[5][k]))
                for k in range(len(xs))]

    def _attitude(self, x: np.ndarray) -> tuple[float, float, float, float, float, float]:
        """φ, θ [rad], p, q, r [rad/s] and ΔaZ [g] from the TF state (eq. 3.4, 3.7)."""
        return self._attitude_from(self._C @ x, self._CA @ x)

    @staticmethod
    def _attitude_from(y, yd) -> tuple[float, float, float, float, float, float]:
        d2r = math.pi / 180.0
        phi, theta, r, az = y[0] * d2r, y[1] * d2r, y[2] * d2r, y[3]
        phid, thetad = yd[0] * d2r, yd[1] * d2r  # relative degree 2: CB = 0 (roll, pitch)
        cf, sf = math.cos(phi), math.sin(phi)
        q = (thetad + r * sf) / cf
        p = phid - (q * sf + r * cf) * math.tan(theta)
        return phi, theta, p, q, r, az

    @property
    def yacs_outputs(self) -> dict[str, float]:
        """Current eq. 3.4 outputs in their own units: roll/pitch [deg], yaw rate [deg/s], aZ [g]."""
        y = self._C @ self._x
        return {"roll_deg": float(y[0]), "pitch_deg": float(y[1]),
                "yaw_rate_deg_s": float(y[2]), "az_g": float(y[3])}

    # -- translational part ----------------------------------------------------------------------
    def _deriv(self, y: np.ndarray, att: tuple, wind_ned: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 3.9 with the thrust T = −g(1 + ΔaZ) of eq. 3.10: d/dt of (u v w N E D ψ w_yacs) and the
        specific force (the air-relative drag and the thrust, body axes)."""
        P = self.params
        phi, theta, p, q, r, az = att
        C = euler_to_dcm3(phi, theta, y[6])  # C_bn, eq. 3.2
        v_b = y[0:3]
        v_air = v_b - C.T @ wind_ned  # body velocity relative to the air
        w_hold = y[7] if P.heave_damping == "yacs" else 0.0  # the climb rate the YACS holds
        f = np.array([P.Xu * v_air[0], P.Yv * v_air[1], P.Zw * (v_air[2] - w_hold) - P.g * (1.0 + az)])
        dv = f - cross3((p, q, r), v_b) + P.g * C[2]  # eq. 3.9: f − ω × v + C_nb (0, 0, g)
        return np.concatenate([dv, C @ v_b, [_psi_rate(att), -P.g * az]]), f

    def _saturate(self, command: YacsCommand) -> np.ndarray:
        raw = (float(command.ail), float(command.ele), float(command.rud), float(command.thr))
        if not math.isfinite(raw[0] + raw[1] + raw[2] + raw[3]):
            raise ValueError(f"command must be finite, got {command}")
        lim, trim = self.params.input_limit, self.params.trim
        return np.array([min(max(tr + r, -lim), lim) - tr for r, tr in zip(raw, trim)])

    def step(self, command: YacsCommand, dt: float | None = None,
             environment: Environment | None = None) -> VehicleState:
        """Advance by ``dt`` (default: the model's dt) under a held command, in the wind of ``environment``
        (held over the step; the R-MAX model has no ground effect: ``rotor_height_m`` is not used).

        The eq. 3.4 states move by their exact ZOH discretisation; the translational states by
        RK4 on ``_deriv``."""
        wind_ned = None if environment is None else environment.wind_ned
        dt = self.dt if dt is None else float(dt)
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive finite number of seconds, got {dt}")
        w = np.zeros(3) if wind_ned is None else np.asarray(wind_ned, dtype=float)
        if w.shape != (3,) or not all(map(math.isfinite, w.tolist())):
            raise ValueError(f"wind_ned must be 3 finite NED values [m/s], got {wind_ned}")
        Ad, Bd, _, _, Ah, Bh = self._matrices(dt)
        u = self._saturate(command)
        x0 = self._x
        xh, x1 = Ah @ x0 + Bh @ u, Ad @ x0 + Bd @ u  # exact TF states at t, t + dt/2, t + dt
        a0, ah, a1 = self._attitudes(x0, xh, x1)
        y, f1 = self._y, None
        if self.on_ground and self._down_accel(y, a0, w) < 0.0:  # net upward force: lift off
            self.on_ground = False
        if self.on_ground:  # skids hold the position; attitude still follows eq. 3.4
            y1 = y.copy()
            y1[6] += dt * (_psi_rate(a0) + 4 * _psi_rate(ah) + _psi_rate(a1)) / 6.0
        elif self.kernel:  # the same RK4, compiled (vehicles/kernels, held to _deriv by tests/vehicles/test_kernels)
            y1, f1 = rmax_rk4(self.params, y.tolist(), a0, ah, a1, w.tolist(), dt)  # and the force at y1
            y1 = np.array(y1)
        else:  # RK4, the attitude at t, t + dt/2 and t + dt from the exact TF states
            k1 = self._deriv(y, a0, w)[0]
            k2 = self._deriv(y + 0.5 * dt * k1, ah, w)[0]
            k3 = self._deriv(y + 0.5 * dt * k2, ah, w)[0]
            k4 = self._deriv(y + dt * k3, a1, w)[0]
            y1 = y + dt * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        C1 = euler_to_dcm3(a1[0], a1[1], y1[6])  # C_bn at t + dt, eq. 3.2
        if not self.on_ground:
            vd = float(C1[2] @ y1[0:3])  # NED down speed
            if y1[5] >= 0.0 and vd > 0.0:  # touchdown
                self.touchdown_speed = vd
                self.on_ground = True
        if self.on_ground:
            y1[0] = y1[1] = y1[2] = y1[5] = y1[7] = 0.0
        self._x, self._y, self.last_input = x1, y1, u
        self.t = round(self.t + dt, 12)  # no float drift over long runs
        self.state = self._make_state(w, a1, C1, None if self.on_ground or f1 is None else np.array(f1))
        return self.state

    def _down_accel(self, y: np.ndarray, att: tuple, wind: np.ndarray) -> float:
        """NED down component of the acceleration the vehicle would have at rest."""
        y0 = np.array(y, dtype=float)
        y0[0:3] = 0.0
        d, _ = self._deriv(y0, att, wind)
        return float(euler_to_dcm3(att[0], att[1], y[6])[2] @ d[0:3])

    def _make_state(self, wind, att: tuple | None = None, C: np.ndarray | None = None,
                    f: np.ndarray | None = None) -> VehicleState:
        """The reported state at ``self.t``; ``C`` (C_bn) and ``f`` (the specific force) where the step has them."""
        if att is None:
            att = self._attitude(self._x)
        phi, theta, p, q, r, _ = att
        y = self._y
        if C is None:
            C = euler_to_dcm3(phi, theta, y[6])
        if f is None:
            if self.on_ground:  # the ground carries the weight: f = -C_nb (0, 0, g)
                f = -self.params.g * C[2]
            elif self.kernel:  # the same, compiled (vehicles/kernels)
                f = np.array(rmax_derivatives(self.params, y.tolist(), att, np.asarray(wind, float).tolist(), True)[1])
            else:  # f_b = a_b − C_nb g_n = air-relative drag + thrust (eq. 3.9)
                f = self._deriv(y, att, np.asarray(wind, float))[1]
        psi = (y[6] + math.pi) % (2 * math.pi) - math.pi
        return VehicleState(t=self.t, position=y[3:6].copy(), velocity=C @ y[0:3],
                            euler=np.array([phi, theta, psi]), body_rates=np.array([p, q, r]),
                            specific_force=f, on_ground=self.on_ground)
