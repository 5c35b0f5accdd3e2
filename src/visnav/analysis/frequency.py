"""Frequency sweeps in closed loop: broken-loop response, stability margins, sensor delays.

Seed 000 §5.2: a logarithmic chirp is added to a cyclic actuator while the helicopter hovers on
MPE; the loop is broken at the actuator (injection e, applied x1 = u_c + e, controller output
x2 = u_c), so L(jω) = −X2/X1 (Tables 5.1, 5.2, Figs. 5.5, 5.6). Gain and phase margins come from
``control.stability_margins`` on the measured FRD. Sensor delays come from the phase slope of one
sensor's attitude against another's (camera vs IMU pitch: the IMU was 44 ms late, Figs. 5.2-5.4).

Spectra (on a log-spaced grid): for a chirp, DFTs of the whole record with the cross-products
summed over a relative bandwidth; for stationary excitation, Welch/CSD estimates (``scipy.signal``)
over several window lengths combined per frequency with weights 2·n_d·γ²/(1 − γ²) (the inverse
random-error variance, γ² corrected for the bias of few averages: CIPHER's composite windows).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import control as ct
import numpy as np
from scipy import signal

from visnav.control.rmax import AxisMargins

AXIS_INDEX = {"lateral": 0, "longitudinal": 1}  # column of (ail, ele, rud, thr) in the log


@dataclass(frozen=True)
class FrequencyResponse:
    """H(jω) on a log grid with its magnitude-squared coherence (NaN where no window applies)."""

    w_rad_s: np.ndarray
    H: np.ndarray
    coherence: np.ndarray

    @property
    def magnitude_db(self) -> np.ndarray:
        return 20.0 * np.log10(np.abs(self.H))

    @property
    def phase_deg(self) -> np.ndarray:
        return np.degrees(np.unwrap(np.angle(self.H)))


@dataclass(frozen=True)
class DelayEstimate:
    """Delay of ``x_late`` behind ``x_ref`` from the cross-spectrum phase slope (NaN if unusable)."""

    delay_s: float
    std_s: float  # 1-sigma from the coherence of the bins used
    n_bins: int
    f_hz: np.ndarray  # the bins used
    phase_rad: np.ndarray  # their unwrapped phase
    coherence: np.ndarray

    @property
    def ok(self) -> bool:
        return bool(np.isfinite(self.delay_s))


# --------------------------------------------------------------------------- spectra
def _signals(fs: float, f_lo: float, f_hi: float, *xs) -> list[np.ndarray]:
    if not (np.isfinite(fs) and fs > 0):
        raise ValueError(f"fs must be a positive sample rate [Hz], got {fs}")
    if not (0 < f_lo < f_hi):
        raise ValueError(f"need 0 < f_lo < f_hi, got f_lo={f_lo}, f_hi={f_hi}")
    if f_hi > fs / 2:
        raise ValueError(f"f_hi={f_hi} Hz is above the Nyquist frequency {fs / 2} Hz")
    out = [np.asarray(x, float) for x in xs]
    n = out[0].shape
    for i, x in enumerate(out):
        if x.ndim != 1 or x.shape != n:
            raise ValueError(f"signal {i} must be 1-D with {n[0]} samples like the first, got shape {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"signal {i} has non-finite samples")
    if n[0] < 16:
        raise ValueError(f"need at least 16 samples, got {n[0]}")
    return out


def _npersegs(n: int, nperseg) -> list[int]:
    if nperseg is None:
        return sorted({max(16, int(n / d)) for d in (2.0, 3.0, 4.5, 7.0)})
    segs = [int(s) for s in np.atleast_1d(nperseg)]
    if any(s < 8 or s > n for s in segs):
        raise ValueError(f"nperseg must be between 8 and the record length {n}, got {nperseg}")
    return segs


def _welch(u: np.ndarray, ys: list[np.ndarray], fs: float, nperseg: int):
    """(f, S_uu, [S_uy], [S_yy], n_segments): Hann windows, 2/3 overlap, linear detrend."""
    kw = dict(fs=fs, window="hann", nperseg=nperseg, noverlap=(2 * nperseg) // 3, detrend="linear")
    f, Suu = signal.welch(u, **kw)
    Suy = [signal.csd(u, y, **kw)[1] for y in ys]
    Syy = [signal.welch(y, **kw)[1] for y in ys]
    return f, Suu, Suy, Syy, 1 + (len(u) - nperseg) // (nperseg - (2 * nperseg) // 3)


def _combine(f_grid: np.ndarray, parts, min_cycles: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Weighted average over windows of (f, H, γ², n_seg, T) interpolated to ``f_grid``; a window
    counts where it holds at least ``min_cycles`` periods."""
    num = np.zeros(f_grid.shape, complex)
    coh = np.zeros(f_grid.shape)
    wsum = np.zeros(f_grid.shape)
    for f, H, g2, nseg, T in parts:
        Hi = np.interp(f_grid, f, H.real) + 1j * np.interp(f_grid, f, H.imag)
        gi = np.clip(np.interp(f_grid, f, g2), 0.0, 0.999)
        n = 0.6 * nseg  # independent averages of Hann windows at 2/3 overlap (about)
        gc = np.clip((n * gi - 1.0) / (n - 1.0), 0.0, 0.999) if n > 1.5 else np.zeros_like(gi)  # unbiased γ²
        wt = np.where(f_grid * T >= min_cycles, 2.0 * n * gc / (1.0 - gc) + 1e-9, 0.0)  # all 0: mean
        num += wt * Hi
        coh += wt * gi
        wsum += wt
    with np.errstate(invalid="ignore", divide="ignore"):
        return num / wsum, coh / wsum


def _band_spectra(u: np.ndarray, ys: list[np.ndarray], fs: float, f_grid: np.ndarray,
                  rel_bandwidth: float, min_bins: int = 3):
    """S_uu, [S_uy], [S_yy] at ``f_grid``: DFTs of the whole (linearly detrended) records, products
    summed over the bins within ±max(rel_bandwidth·f/2, min_bins·df/2) of each grid frequency."""
    if not rel_bandwidth > 0:
        raise ValueError(f"rel_bandwidth must be > 0, got {rel_bandwidth}")
    n = len(u)
    f = np.fft.rfftfreq(n, 1.0 / fs)
    U, Ys = np.fft.rfft(signal.detrend(u)), [np.fft.rfft(signal.detrend(y)) for y in ys]
    half = np.maximum(rel_bandwidth * f_grid / 2, 0.5 * min_bins * fs / n)
    lo, hi = np.searchsorted(f, f_grid - half, "left"), np.searchsorted(f, f_grid + half, "right")

    def band(p: np.ndarray) -> np.ndarray:
        c = np.concatenate([[0.0], np.cumsum(p)])
        return c[hi] - c[lo]

    return band(np.abs(U) ** 2), [band(np.conj(U) * Y) for Y in Ys], [band(np.abs(Y) ** 2) for Y in Ys]


def _estimate(u, ys, fs, f_grid, method, rel_bandwidth, nperseg, ratio) -> tuple[np.ndarray, np.ndarray]:
    """(H, γ²) = ratio(S_uu, [S_uy], [S_yy]) by the chosen spectral method, at ``f_grid``."""
    with np.errstate(invalid="ignore", divide="ignore"):
        if method == "fft":
            return ratio(*_band_spectra(u, ys, fs, f_grid, rel_bandwidth))
        if method == "welch":
            parts = []
            for seg in _npersegs(len(u), nperseg):
                f, Suu, Suy, Syy, nseg = _welch(u, ys, fs, seg)
                parts.append((f, *ratio(Suu, Suy, Syy), nseg, seg / fs))
            return _combine(f_grid, parts)
    raise ValueError(f"method must be 'fft' or 'welch', got {method!r}")


def _grid(f_lo: float, f_hi: float, n_points: int) -> np.ndarray:
    if n_points < 2:
        raise ValueError(f"n_points must be >= 2, got {n_points}")
    return np.geomspace(f_lo, f_hi, n_points)


def frequency_response(u, y, fs: float, f_lo: float, f_hi: float, method: str = "fft",
                       rel_bandwidth: float = 0.3, nperseg=None, n_points: int = 80) -> FrequencyResponse:
    """H1 estimate H = S_uy / S_uu with coherence γ² = |S_uy|² / (S_uu S_yy), on ``n_points``
    log-spaced frequencies in [f_lo, f_hi] Hz.

    ``method="fft"``: spectra of the whole record smoothed over a relative bandwidth (right for a
    chirp: Welch windows shorter than the loop's memory bias a 40 s sweep's phase margin by ~10°);
    ``"welch"``: composite Welch windows (``nperseg``: one length or several; default the record
    over 2, 3, 4.5 and 7), for stationary excitation."""
    u, y = _signals(fs, f_lo, f_hi, u, y)

    def ratio(Suu, Suy, Syy):
        return Suy[0] / Suu, np.abs(Suy[0]) ** 2 / (Suu * Syy[0])

    fg = _grid(f_lo, f_hi, n_points)
    return FrequencyResponse(2 * np.pi * fg, *_estimate(u, [y], fs, fg, method, rel_bandwidth, nperseg, ratio))


def broken_loop_from_signals(e, x1, x2, fs: float, f_lo: float, f_hi: float, method: str = "fft",
                             rel_bandwidth: float = 0.3, nperseg=None, n_points: int = 80) -> FrequencyResponse:
    """L(jω) = −X2/X1 = −S_e,x2 / S_e,x1 with the injection e as instrument (noise in x1, x2 does
    not bias it); coherence = min(γ²_e,x1, γ²_e,x2). Options as ``frequency_response``."""
    e, x1, x2 = _signals(fs, f_lo, f_hi, e, x1, x2)

    def ratio(See, S, Sxx):
        return -S[1] / S[0], np.minimum(np.abs(S[0]) ** 2 / (See * Sxx[0]), np.abs(S[1]) ** 2 / (See * Sxx[1]))

    fg = _grid(f_lo, f_hi, n_points)
    L, g2 = _estimate(e, [x1, x2], fs, fg, method, rel_bandwidth, nperseg, ratio)
    return FrequencyResponse(2 * np.pi * fg, L, g2)


def broken_loop_response(log, axis: str, f_lo: float = 0.1, f_hi: float = 2.5, **kw) -> FrequencyResponse:
    """Broken-loop response at the ``axis`` cyclic actuator from the log's "actuator" stream."""
    if axis not in AXIS_INDEX:
        raise ValueError(f"axis must be one of {sorted(AXIS_INDEX)}, got {axis!r}")
    a = log.get("actuator") if "actuator" in log else {}
    if not a or len(a["t"]) < 16:
        raise ValueError("the log has no 'actuator' stream (no sweep was injected)")
    t, i = np.asarray(a["t"]), AXIS_INDEX[axis]
    dt = np.diff(t)
    if np.any(np.abs(dt - np.median(dt)) > 0.01 * np.median(dt)):
        raise ValueError("the 'actuator' stream is not uniformly sampled (sweep interrupted?)")
    return broken_loop_from_signals(a["injection"][:, i], a["applied"][:, i], a["controller"][:, i],
                                    1.0 / float(np.median(dt)), f_lo, f_hi, **kw)


# --------------------------------------------------------------------------- margins
def _select(gm, pm, w180, wc) -> AxisMargins:
    """The rule of ``control.rmax.loop_margins``: the gain crossover with the smallest |PM|; the GM
    is the smallest of the phase crossings above it (gain increase), in dB."""
    gm, pm, w180, wc = (np.atleast_1d(np.asarray(a, float)) for a in (gm, pm, w180, wc))
    if pm.size == 0:
        return AxisMargins(gm_db=math.nan, pm_deg=math.inf, w_gc=math.nan, w_pc=math.nan)
    i = int(np.argmin(np.abs(pm)))
    j = np.flatnonzero((w180 > wc[i]) & (gm > 0))
    if j.size == 0:
        return AxisMargins(gm_db=math.inf, pm_deg=float(pm[i]), w_gc=float(wc[i]), w_pc=math.nan)
    k = j[np.argmin(gm[j])]
    return AxisMargins(gm_db=float(20 * np.log10(gm[k])), pm_deg=float(pm[i]), w_gc=float(wc[i]),
                       w_pc=float(w180[k]))


def interpolated_margins(w, L) -> AxisMargins:
    """Margins by linear interpolation between grid points (log ω; log|L| for gain crossings, the
    angle of −L for phase crossings): the cross-check of ``margins_from_frd``."""
    w, L = np.asarray(w, float), np.asarray(L, complex)
    lm, ang = np.log(np.abs(L)), np.angle(-L)  # ang = 0 on the negative real axis
    lw = np.log(w)
    ic = np.flatnonzero(np.sign(lm[:-1]) != np.sign(lm[1:]))
    a = lm[ic] / (lm[ic] - lm[ic + 1])
    wc = np.exp(lw[ic] + a * (lw[ic + 1] - lw[ic]))
    dph = np.angle(L[ic + 1] / L[ic])
    pm = np.remainder(np.degrees(np.angle(L[ic]) + a * dph), 360.0) - 180.0
    ip = np.flatnonzero((np.sign(ang[:-1]) != np.sign(ang[1:])) & (np.abs(ang[1:] - ang[:-1]) < np.pi))
    b = ang[ip] / (ang[ip] - ang[ip + 1])
    w180 = np.exp(lw[ip] + b * (lw[ip + 1] - lw[ip]))
    gm = np.exp(-(lm[ip] + b * (lm[ip + 1] - lm[ip])))
    return _select(gm, pm, w180, wc)


def margins_from_frd(w, L, coherence=None, min_coherence: float = 0.6,
                     method: str = "control") -> AxisMargins:
    """Gain and phase margins of a measured loop L(jω) at ``w`` [rad/s] (points with coherence
    below ``min_coherence`` dropped). ``method``: "control" = ``control.stability_margins`` on
    ``control.frd`` (spline-interpolated FRD); "interp" = ``interpolated_margins``."""
    w, L = np.asarray(w, float).ravel(), np.asarray(L, complex).ravel()
    if w.shape != L.shape:
        raise ValueError(f"w and L must have the same length, got {w.size} and {L.size}")
    keep = np.isfinite(w) & np.isfinite(L) & (w > 0)
    if coherence is not None:
        keep &= np.nan_to_num(np.asarray(coherence, float).ravel()) >= min_coherence
    w, L = w[keep], L[keep]
    if w.size < 4:
        raise ValueError(f"need at least 4 usable frequency points, got {w.size}")
    if np.any(np.diff(w) <= 0):
        raise ValueError("w must be strictly increasing")
    if method == "interp":
        return interpolated_margins(w, L)
    if method != "control":
        raise ValueError(f"method must be 'control' or 'interp', got {method!r}")
    gm, pm, _, w180, wc, _ = ct.stability_margins(ct.frd(L, w), returnall=True)
    return _select(gm, pm, w180, wc)


# --------------------------------------------------------------------------- delays
def identify_delay(x_ref, x_late, fs: float, f_lo: float, f_hi: float, nperseg: int | None = None,
                   min_coherence: float = 0.6) -> DelayEstimate:
    """Delay τ of ``x_late`` behind ``x_ref`` (seed 000 Figs. 5.2-5.4): H = S_ref,late / S_ref,ref
    ≈ e^{−jωτ}; τ = −Σ W ω φ / Σ W ω² over the Welch bins in [f_lo, f_hi] with γ² ≥
    ``min_coherence`` (phase unwrapped across the band, W = 2 n_d γ²/(1 − γ²)); unambiguous for
    |τ| < 1/(2 f_lo). NaN when fewer than 3 bins are coherent."""
    x_ref, x_late = _signals(fs, f_lo, f_hi, x_ref, x_late)
    n = len(x_ref)
    seg = int(nperseg) if nperseg else int(min(n // 3, 2 ** math.ceil(math.log2(4 * fs / f_lo))))
    if not 8 <= seg <= n:
        raise ValueError(f"nperseg must be between 8 and the record length {n}, got {seg}")
    f, Srr, (Srl,), (Sll,), nseg = _welch(x_ref, [x_late], fs, seg)
    band = (f >= f_lo) & (f <= f_hi)
    with np.errstate(invalid="ignore", divide="ignore"):
        g2 = np.abs(Srl[band]) ** 2 / (Srr[band] * Sll[band])
    ph = np.unwrap(np.angle(Srl[band]))
    fb = f[band]
    ok = np.nan_to_num(g2) >= min_coherence
    if ok.sum() < 3:
        return DelayEstimate(math.nan, math.nan, int(ok.sum()), fb[ok], ph[ok], g2[ok])
    om = 2 * np.pi * fb[ok]
    g = np.clip(g2[ok], 0.0, 0.999)
    W = 2.0 * nseg * g / (1.0 - g)
    tau = -float(np.sum(W * om * ph[ok]) / np.sum(W * om * om))
    return DelayEstimate(tau, float(1.0 / np.sqrt(np.sum(W * om * om))), int(ok.sum()), fb[ok], ph[ok], g2[ok])


def identify_delay_series(t_ref, x_ref, t_late, x_late, f_lo: float, f_hi: float, **kw) -> DelayEstimate:
    """``identify_delay`` for time-stamped series at any rates: both are interpolated linearly onto
    a uniform grid at the reference's median rate over their common time span."""
    t_ref, x_ref, t_late, x_late = (np.asarray(a, float) for a in (t_ref, x_ref, t_late, x_late))
    for name, t, x in (("ref", t_ref, x_ref), ("late", t_late, x_late)):
        if t.ndim != 1 or t.shape != x.shape or t.size < 16:
            raise ValueError(f"t_{name} and x_{name} must be 1-D of one length >= 16, got {t.shape}, {x.shape}")
        if np.any(np.diff(t) <= 0):
            raise ValueError(f"t_{name} must be strictly increasing")
    dt = float(np.median(np.diff(t_ref)))
    t0, t1 = max(t_ref[0], t_late[0]), min(t_ref[-1], t_late[-1])
    grid = np.arange(t0, t1 + 1e-9, dt)
    return identify_delay(np.interp(grid, t_ref, x_ref), np.interp(grid, t_late, x_late), 1.0 / dt,
                          f_lo, f_hi, **kw)


def camera_attitude(x_px, y_px, focal_px: float, principal_point: tuple[float, float],
                    depression_rad: float, axis: str) -> np.ndarray:
    """Pitch or roll [rad, up to a constant] from a tracked ground point's pixel (OpenCV axes).

    Camera x = body y; the optical axis is ``depression_rad`` below body x. A body rotation dθ
    about y turns the ray's elevation by dθ: y = cy + f tan(α), α = α0 + θ. A rotation dφ about
    body x has the component sin(δ) across the ray, δ = depression + α (the ray below body x):
    dx ≈ f sin(δ) dφ. Vehicle translation adds f·Δp/R: small above g/(ω² R) (sweeps ≳ 0.5 Hz);
    the lever arm (camera ahead of and above the reference point) turns a few % of the rotation
    into translation: a gain error, not a phase error, so delays come out unbiased.
    """
    f = float(focal_px)
    cx, cy = principal_point
    alpha = np.arctan((np.asarray(y_px, float) - cy) / f)
    if axis == "pitch":
        return alpha
    if axis == "roll":
        return np.arctan((np.asarray(x_px, float) - cx) / f) / np.sin(depression_rad + alpha)
    raise ValueError(f"axis must be 'pitch' or 'roll', got {axis!r}")


def _sweep_window(log) -> tuple[float, float]:
    a = log.get("actuator") if "actuator" in log else {}
    if not a:
        raise ValueError("the log has no 'actuator' stream (no sweep was injected)")
    return float(a["t"][0]), float(a["t"][-1])


def identify_imu_delay(log, focal_px: float, principal_point: tuple[float, float], depression_deg: float,
                       axis: str = "pitch", f_lo: float = 0.5, f_hi: float = 2.5, **kw) -> DelayEstimate:
    """Delay of the IMU attitude ("attitude_samples", as the navigator received them, at their
    stamps) behind the camera-derived attitude ("tracker" pixels) during the log's sweep."""
    t0, t1 = _sweep_window(log)
    tr = log.get("tracker") if "tracker" in log else {}
    att = log.get("attitude_samples") if "attitude_samples" in log else {}
    if not tr or not att:
        raise ValueError("the log needs the 'tracker' and 'attitude_samples' streams")
    t = np.asarray(tr["t"], float)
    idx = np.flatnonzero((t >= t0) & (t <= t1) & np.asarray(tr.get("ok", np.ones_like(t)), bool))
    if idx.size < 16:
        raise ValueError(f"only {idx.size} tracked frames during the sweep")
    dt = np.diff(t[idx])
    runs = np.split(idx, np.flatnonzero(dt > 1.5 * np.median(dt)) + 1)  # frames lost: longest run
    sel = max(runs, key=len)
    cam = camera_attitude(tr["x"][sel], tr["y"][sel], focal_px, principal_point, math.radians(depression_deg),
                          axis)
    ta = np.asarray(att["t"], float)
    imu = np.asarray(att["euler"], float)[:, 0 if axis == "roll" else 1]
    return identify_delay_series(t[sel], cam, ta, imu, f_lo, min(f_hi, 0.45 / np.median(dt)), **kw)


# --------------------------------------------------------------------------- analytic model
@functools.lru_cache(maxsize=32)
def _filter_gains(accel_noise: float = 0.3, sigma_m: float = 0.02, imu_rate_hz: float = 100.0,
                  update_rate_hz: float = 10.0) -> tuple[float, float]:
    """Steady-state (K_p, K_v) of the navigator's PositionFilter per position update, found by
    running its own covariance recursion to convergence."""
    from visnav.estimation.position_filter import PositionFilter

    f = PositionFilter(accel_noise, np.zeros(3), np.zeros(3))
    f.t, n = 0.0, max(1, int(round(imu_rate_hz / update_rate_hz)))
    k = (0.0, 0.0)
    for i in range(400):
        for j in range(n):
            f.predict((i * n + j + 1) / imu_rate_hz, np.zeros(3))
        s = f.P00[0] + sigma_m**2
        k = (f.P00[0] / s, f.P01[0] / s)
        f.update_position(np.zeros(3), sigma_m)
    return k


def _model(axis: str, s, delay, altitude_m: float, delay_s: float | None, compensation_s: float,
           gains, rate_hz: float, filter_gains):
    """The loop of ``model_loop`` with ``s`` = jω (array) or ``control.tf('s')`` and ``delay(t)`` =
    e^{−st} or its Padé approximation."""
    from visnav.control.rmax import DRAG, RmaxPositionGains

    if axis not in AXIS_INDEX:
        raise ValueError(f"axis must be one of {sorted(AXIS_INDEX)}, got {axis!r}")
    if not (np.isfinite(altitude_m) and altitude_m > 0):
        raise ValueError(f"altitude_m must be > 0, got {altitude_m}")
    if delay_s is not None and not (np.isfinite(delay_s) and delay_s >= 0):
        raise ValueError(f"delay_s must be >= 0 or None (GPS), got {delay_s}")
    if not (np.isfinite(compensation_s) and compensation_s >= 0):
        raise ValueError(f"compensation_s must be >= 0, got {compensation_s}")
    T = 1.0 / rate_hz
    k = gains or RmaxPositionGains()
    kp, kd, ki = (k.kp_lat, k.kd_lat, k.ki_lat) if axis == "lateral" else (k.kp_lon, k.kd_lon, k.ki_lon)
    D = DRAG["y"] if axis == "lateral" else DRAG["x"]
    hold = delay(T / 2)
    tau = 0.0 if delay_s is None else float(delay_s)
    M = 1 - altitude_m / 9.81 * s * (s - D) * (1 - delay(tau - compensation_s)) if delay_s is not None else 1
    kpos, kvel = filter_gains or _filter_gains(update_rate_hz=rate_hz)
    k1, k2 = kpos / T, kvel / T
    den = s * s + k1 * s + k2
    p_hat = (k1 * s + k2) / den * M * hold + s * s / den * delay(tau)
    v_hat = s * p_hat + k1 * (p_hat - M * hold)
    return ((kp + ki / s) * p_hat + kd * v_hat) * hold


def model_loop(axis: str, w, altitude_m: float = 12.0, delay_s: float | None = 0.0,
               compensation_s: float = 0.0, gains=None, rate_hz: float = 10.0,
               filter_gains: tuple[float, float] | None = None) -> np.ndarray:
    """L(jω) at the cyclic actuator of the R-MAX position loop flying on MPE (``delay_s`` None: GPS).

    Attitude late by τ' = delay_s − compensation_s tilts MPE's line of sight: the fix errs by
    h·(θ(t) − θ(t−τ')) in x and −h·(φ(t) − φ(t−τ')) in y (h the height: the vertical of the range
    vector R, R·sin 60°). With the position dynamics θ = −s(s−X_u)x/g (φ = s(s−Y_v)y/g) the MPE
    fix is y_m = M(s)·x, M = 1 − (h/g)s(s−D)(1 − e^{−sτ'}). The navigator's Kalman filter
    (steady-state gains K_p, K_v per 10 Hz fix; K1 = K_p/T, K2 = K_v/T) blends it with the IMU
    acceleration, itself late by τ: p̂ = F_l·M·e^{−sT/2}·x + F_h·e^{−sτ}·x, F_l = (K1 s + K2)/Δ,
    F_h = s²/Δ, Δ = s² + K1 s + K2, v̂ = s p̂ + K1 (p̂ − y_m e^{−sT/2}); the PID acts on p̂ and v̂:
    L = [(Kp + Ki/s) p̂/x + Kd v̂/x]·P(s)·e^{−sT/2}, P the eq. 3.4 plant of
    ``control.rmax.normalized_plant`` and e^{−sT/2} the 10 Hz hold. With τ = τ' = 0 (and for GPS)
    p̂ = x up to the hold: L reduces to ``control.rmax.position_loop``.
    """
    from visnav.control.rmax import _freq, normalized_plant

    w = np.asarray(w, float)
    s = 1j * w
    L = _model(axis, s, lambda t: np.exp(-s * t), altitude_m, delay_s, compensation_s, gains, rate_hz,
               filter_gains)
    return L * _freq(normalized_plant(axis, 0.0), w)


def model_margins(altitude_m: float, delay_s: float | None, axis: str = "lateral",
                  compensation_s: float = 0.0, w_max: float = 2 * np.pi * 2.5, **kw) -> AxisMargins:
    """Margins of ``model_loop`` by ``margins_from_frd`` on 0.05 rad/s .. ``w_max`` (the band a
    sweep measures; the model is no good near the 10 Hz loop's Nyquist frequency anyway)."""
    w = np.geomspace(0.05, w_max, 1500)
    return margins_from_frd(w, model_loop(axis, w, altitude_m, delay_s, compensation_s, **kw))


def model_stable(altitude_m: float, delay_s: float | None, axis: str = "lateral",
                 compensation_s: float = 0.0, pade_order: int = 5, **kw) -> bool:
    """Closed-loop stability of ``model_loop`` (delays as Padé approximations; a compensation
    beyond the delay counts as exact)."""
    from visnav.control.rmax import normalized_plant

    def delay(t: float):
        return ct.tf(*ct.pade(t, pade_order)) if t > 0 else ct.tf([1.0], [1.0])

    L = _model(axis, ct.tf("s"), delay, altitude_m, delay_s, compensation_s, kw.get("gains"),
               kw.get("rate_hz", 10.0), kw.get("filter_gains")) * normalized_plant(axis, 0.0)
    return bool(np.all(ct.poles(ct.feedback(L, 1)).real < 0))


# --------------------------------------------------------------------------- campaigns
@dataclass(frozen=True)
class SweepSettings:
    """The chirp injected at the actuator (YACS units, Hz, s) and the analysis settings.

    The amplitude shrinks below ``amplitude_ref_altitude_m`` (to ``min_amplitude_fraction``): close
    to the ground the same tilt moves the tracked point faster and the tracker loses it. Phase
    crossovers where the coherence stays below ``min_coherence`` (MPE noise grows with height) are
    read from points down to ``gm_min_coherence`` and flagged."""

    amplitude: float = 40.0
    f0_hz: float = 0.08
    f1_hz: float = 2.5
    duration_s: float = 80.0
    start_s: float = 3.0
    amplitude_ref_altitude_m: float = 12.0
    min_amplitude_fraction: float = 0.75
    delay_band_hz: tuple[float, float] = (0.5, 2.5)
    min_coherence: float = 0.6
    gm_min_coherence: float = 0.3

    def amplitude_at(self, altitude_m: float) -> float:
        scale = min(1.0, max(self.min_amplitude_fraction, altitude_m / self.amplitude_ref_altitude_m))
        return self.amplitude * scale

    def overrides(self, altitude_m: float) -> list[str]:
        return [f"mission.sweep_amplitude={self.amplitude_at(altitude_m)}", f"mission.sweep_f0_hz={self.f0_hz}",
                f"mission.sweep_f1_hz={self.f1_hz}", f"mission.sweep_duration_s={self.duration_s}",
                f"mission.sweep_start_s={self.start_s}", f"mission.hold_s={self.start_s + self.duration_s + 1.0}",
                f"run.duration_s={self.start_s + self.duration_s + 30.0}"]


def sweep_run(altitude_m: float, axis: str, source: str = "mpe", imu_delay_s: float = 0.0,
              attitude_delay_s: float = 0.0, seed: int = 1, sweep: SweepSettings = SweepSettings(),
              scenario: str = "palace-sweep", overrides: tuple[str, ...] = ()) -> dict:
    """One hover with a chirp at the ``axis`` actuator: its margins (NaN when the sweep did not
    complete), the IMU delay identified from the same sweep (roll for lateral, pitch for
    longitudinal) and notes (track lost, sweep cut short, point near the image edge)."""
    from visnav.scenarios.schema import load_scenario
    from visnav.sim.loop import Simulation

    if axis not in AXIS_INDEX:
        raise ValueError(f"axis must be one of {sorted(AXIS_INDEX)}, got {axis!r}")
    ov = [*overrides, f"mission.altitude_m={altitude_m}", f'mission.source="{source}"',
          f'mission.sweep_axis="{axis}"', f"sensors.imu.delay_s={imu_delay_s}",
          f"navigation.mpe.attitude_delay_s={attitude_delay_s}", *sweep.overrides(altitude_m)]
    sc = load_scenario(scenario, ov, seed=seed)
    res = Simulation(sc).run()
    log, notes = res.log, []
    out = dict(pm_deg=math.nan, w_gc=math.nan, gm_db=math.nan, w_pc=math.nan, delay_s=math.nan,
               delay_std_s=math.nan, notes=notes)
    if res.error:
        notes.append(res.error)
    modes = list(log.get("mode").get("mode", [])) if "mode" in log else []
    if "lost" in modes:
        notes.append(f"track lost at {log.get('mode')['t'][modes.index('lost')]:.1f} s")
    a = log.get("actuator") if "actuator" in log else {}
    if not a or a["t"][-1] - a["t"][0] < 0.95 * sweep.duration_s:
        notes.append("sweep incomplete: loop unstable or track lost")
        return out
    cam = sc.sensors.camera
    tr = log.get("tracker")
    sel = (tr["t"] >= a["t"][0]) & (tr["t"] <= a["t"][-1])
    x, y = tr["x"][sel], tr["y"][sel]
    edge = min(x.min(), cam.width - x.max(), y.min(), cam.height - y.max())
    if edge < 40:
        notes.append(f"tracked point within {edge:.0f} px of the image edge")
    fr = broken_loop_response(log, axis, sweep.f0_hz, 0.9 * sweep.f1_hz)  # the chirp's ends are weak
    try:
        m = margins_from_frd(fr.w_rad_s, fr.H, fr.coherence, sweep.min_coherence)
        out.update(pm_deg=m.pm_deg, w_gc=m.w_gc, gm_db=m.gm_db, w_pc=m.w_pc)
        if not np.isfinite(m.w_pc):
            g = margins_from_frd(fr.w_rad_s, fr.H, fr.coherence, sweep.gm_min_coherence)
            if np.isfinite(g.w_pc):
                i = np.argmin(np.abs(fr.w_rad_s - g.w_pc))
                out.update(gm_db=g.gm_db, w_pc=g.w_pc)
                notes.append(f"GM read at coherence {fr.coherence[i]:.2f} (low confidence)")
    except ValueError as exc:
        notes.append(f"margins: {exc}")
    lo, hi = sweep.delay_band_hz
    try:
        d = identify_imu_delay(log, cam.focal_px, (cam.width / 2, cam.height / 2), cam.depression_deg,
                               "roll" if axis == "lateral" else "pitch", lo, min(hi, sweep.f1_hz))
        out.update(delay_s=d.delay_s, delay_std_s=d.std_s)
    except ValueError as exc:
        notes.append(f"delay: {exc}")
    return out


def _combine_delays(*runs: dict) -> float:
    """Inverse-variance mean of the finite delay estimates of several sweeps (NaN if none)."""
    d = np.array([r["delay_s"] for r in runs], float)
    s = np.array([r["delay_std_s"] for r in runs], float)
    ok = np.isfinite(d) & np.isfinite(s) & (s > 0)
    return float(np.sum(d[ok] / s[ok] ** 2) / np.sum(1 / s[ok] ** 2)) if ok.any() else math.nan


def _call(kwargs: dict) -> dict:
    return sweep_run(**kwargs)


def margins_campaign(altitudes, delays, compensate: bool = False, seed: int = 1,
                     sweep: SweepSettings = SweepSettings(), scenario: str = "palace-sweep",
                     overrides: tuple[str, ...] = (), workers: int = 1, executor=None,
                     progress=None) -> list[dict]:
    """Tables 5.1/5.2: per altitude a GPS row and per delay an MPE row with the IMU ``delay``
    uncompensated; with ``compensate`` also an MPE row with ``navigation.mpe.attitude_delay_s`` =
    the delay identified from a lateral + longitudinal sweep flown on GPS (MPE open loop, so the
    identification never rides on a loop the delay may destabilise); where identification fails
    the true delay is used and the row's notes say so. Each row is two sweeps (lateral,
    longitudinal). ``executor``: anything with ``submit`` (a process pool, a Dask client's
    executor); else ``workers`` local processes. ``progress(done, total)`` after each run."""
    alts = [float(a) for a in altitudes]
    dls = [float(d) for d in delays]
    if not alts or any(not (np.isfinite(a) and a > 0) for a in alts):
        raise ValueError(f"altitudes must be a non-empty list of heights > 0 m, got {altitudes}")
    if any(not (np.isfinite(d) and d >= 0) for d in dls):
        raise ValueError(f"delays must be >= 0 s, got {delays}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    base = dict(seed=seed, sweep=sweep, scenario=scenario, overrides=tuple(overrides))
    runs: dict[tuple, dict] = {}

    def key(alt, src, delay, comp, axis):
        return (alt, src, delay, round(comp, 6), axis)

    def execute(keys: list[tuple]) -> None:
        todo = [k for k in dict.fromkeys(keys) if k not in runs]
        jobs = [dict(altitude_m=k[0], source=k[1], imu_delay_s=k[2], attitude_delay_s=k[3], axis=k[4], **base)
                for k in todo]
        pool = executor
        own = pool is None and workers > 1
        if own:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor
            pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))
        total = len(runs) + len(todo)
        try:
            futures = [pool.submit(_call, j) for j in jobs] if pool is not None else None
            for i, k in enumerate(todo):
                runs[k] = futures[i].result() if futures is not None else _call(jobs[i])
                if progress is not None:
                    progress(len(runs), total)
        finally:
            if own:
                pool.shutdown()

    axes = ("lateral", "longitudinal")
    first = [key(a, "gps", 0.0, 0.0, ax) for a in alts for ax in axes]
    first += [key(a, "mpe", d, 0.0, ax) for a in alts for d in dls for ax in axes]
    if compensate:
        first += [key(a, "gps", d, 0.0, ax) for a in alts for d in dls for ax in axes]
    execute(first)
    ident = {}
    if compensate:
        for a in alts:
            for d in dls:
                tau = _combine_delays(*(runs[key(a, "gps", d, 0.0, ax)] for ax in axes))
                ident[a, d] = (tau, True) if np.isfinite(tau) else (d, False)
        execute([key(a, "mpe", d, max(ident[a, d][0], 0.0), ax) for a in alts for d in dls for ax in axes])

    def row(a, delay, comp, pair, tau, notes):
        r = dict(altitude_m=a, delay_s=delay, compensated=comp)
        for ax, res in zip(axes, pair):
            r.update({f"{ax}_pm_deg": res["pm_deg"], f"{ax}_pm_wc_rps": res["w_gc"], f"{ax}_gm_db": res["gm_db"]})
        r["identified_imu_delay_s"] = tau
        for ax, res in zip(axes, pair):
            r[f"{ax}_gm_wc_rps"] = res["w_pc"]
        r["notes"] = "; ".join(notes + [f"{ax}: {n}" for ax, res in zip(axes, pair) for n in res["notes"]])
        return r

    rows = []
    for a in alts:
        pair = [runs[key(a, "gps", 0.0, 0.0, ax)] for ax in axes]
        rows.append(row(a, None, "gps", pair, _combine_delays(*pair), []))
        for d in dls:
            pair = [runs[key(a, "mpe", d, 0.0, ax)] for ax in axes]
            tau = _combine_delays(*pair)
            if not np.isfinite(tau) and compensate and ident[a, d][1]:
                tau = ident[a, d][0]
            rows.append(row(a, d, False, pair, tau, []))
            if compensate:
                tau, ok = ident[a, d]
                pair = [runs[key(a, "mpe", d, max(tau, 0.0), ax)] for ax in axes]
                rows.append(row(a, d, True, pair, tau if ok else math.nan,
                                [] if ok else ["identification failed: compensated with the true delay"]))
    return rows
