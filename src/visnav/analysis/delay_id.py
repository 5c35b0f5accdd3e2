"""Sensor-delay identification from a frequency sweep (seed 000 §5.2, Figs. 5.2-5.4).

The phase slope of one sensor's view of the attitude against another's gives their relative delay:
camera-derived pitch against the IMU's (the IMU was 44 ms late, Fig. 5.3), laser-derived pitch
against the IMU's (Fig. 5.4) and camera against laser (no delay, Fig. 5.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from visnav.analysis.frequency import _signals, _welch


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


def laser_attitude(range_m, beam_offset_rad, depression_rad: float) -> np.ndarray:
    """Pitch [rad, up to a constant] from the laser range along the optical axis over flat ground.

    The beam leaves ``depression_rad`` + its scan offset below body x, so at height h it meets the
    ground at R = h / sin(δ + o − θ) (θ pitch, nose up positive): θ = δ + o − asin(h/R), with h
    the mean of R·sin(δ + o) over the record (a constant pitch offset does not move a phase slope).
    Height changes add h'/h·tan(δ) to θ: small at sweep frequencies, where the pitch is what moves.
    """
    r = np.asarray(range_m, float)
    d = depression_rad + np.asarray(beam_offset_rad, float)
    h = float(np.mean(r * np.sin(d)))
    return d - np.arcsin(np.clip(h / r, -1.0, 1.0))


def _sweep_window(log) -> tuple[float, float]:
    a = log.get("actuator") if "actuator" in log else {}
    if not a:
        raise ValueError("the log has no 'actuator' stream (no sweep was injected)")
    return float(a["t"][0]), float(a["t"][-1])


def _camera_series(log, focal_px: float, principal_point: tuple[float, float], depression_deg: float,
                   axis: str) -> tuple[np.ndarray, np.ndarray]:
    """(t, camera-derived attitude) over the longest run of tracked frames during the sweep."""
    t0, t1 = _sweep_window(log)
    tr = log.get("tracker") if "tracker" in log else {}
    if not tr:
        raise ValueError("the log needs the 'tracker' stream (no point was tracked)")
    t = np.asarray(tr["t"], float)
    idx = np.flatnonzero((t >= t0) & (t <= t1) & np.asarray(tr.get("ok", np.ones_like(t)), bool))
    if idx.size < 16:
        raise ValueError(f"only {idx.size} tracked frames during the sweep")
    dt = np.diff(t[idx])
    runs = np.split(idx, np.flatnonzero(dt > 1.5 * np.median(dt)) + 1)  # frames lost: longest run
    sel = max(runs, key=len)
    return t[sel], camera_attitude(tr["x"][sel], tr["y"][sel], focal_px, principal_point,
                                   math.radians(depression_deg), axis)


def _imu_series(log, axis: str) -> tuple[np.ndarray, np.ndarray]:
    att = log.get("attitude_samples") if "attitude_samples" in log else {}
    if not att:
        raise ValueError("the log needs the 'attitude_samples' stream")
    return np.asarray(att["t"], float), np.asarray(att["euler"], float)[:, 0 if axis == "roll" else 1]


def _laser_series(log, depression_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(t, laser-derived pitch) during the sweep (samples without a return dropped)."""
    t0, t1 = _sweep_window(log)
    ls = log.get("laser") if "laser" in log else {}
    if not ls:
        raise ValueError("the log needs the 'laser' stream")
    t, r = np.asarray(ls["t"], float), np.asarray(ls["range"], float)
    off = np.asarray(ls.get("beam_offset", np.zeros_like(r)), float)
    ok = (t >= t0) & (t <= t1) & np.isfinite(r) & (r > 0)
    if ok.sum() < 16:
        raise ValueError(f"only {int(ok.sum())} laser returns during the sweep")
    return t[ok], laser_attitude(r[ok], off[ok], math.radians(depression_deg))


def identify_imu_delay(log, focal_px: float, principal_point: tuple[float, float], depression_deg: float,
                       axis: str = "pitch", f_lo: float = 0.5, f_hi: float = 2.5, **kw) -> DelayEstimate:
    """Delay of the IMU attitude ("attitude_samples", as the navigator received them, at their
    stamps) behind the camera-derived attitude ("tracker" pixels) during the log's sweep (Fig. 5.3)."""
    tc, cam = _camera_series(log, focal_px, principal_point, depression_deg, axis)
    ti, imu = _imu_series(log, axis)
    return identify_delay_series(tc, cam, ti, imu, f_lo, min(f_hi, 0.45 / np.median(np.diff(tc))), **kw)


def identify_laser_delays(log, focal_px: float, principal_point: tuple[float, float], depression_deg: float,
                          f_lo: float = 0.5, f_hi: float = 2.5, **kw) -> dict[str, DelayEstimate]:
    """Pitch seen by the laser against the IMU and the camera during a longitudinal sweep.

    ``imu_vs_laser``: the IMU's delay behind the laser (Fig. 5.4); ``laser_vs_camera``: the laser's
    behind the camera (Fig. 5.2, none in the thesis). With the camera as reference the laser's
    delay is also camera→IMU minus laser→IMU (the issue's "laser against IMU gives each sensor's
    delay"); both ways are returned so they can be checked against each other."""
    tl, las = _laser_series(log, depression_deg)
    ti, imu = _imu_series(log, "pitch")
    fmax = min(f_hi, 0.45 / np.median(np.diff(tl)))
    out = {"imu_vs_laser": identify_delay_series(tl, las, ti, imu, f_lo, fmax, **kw)}
    tc, cam = _camera_series(log, focal_px, principal_point, depression_deg, "pitch")
    out["laser_vs_camera"] = identify_delay_series(tc, cam, tl, las, f_lo, min(fmax, 0.45 / np.median(np.diff(tc))),
                                                   **kw)
    return out


@dataclass(frozen=True)
class CombinedDelay:
    """Several identifications of one delay (seeds, axes) combined (``combine_delays``)."""

    delay_s: float  # weighted mean of the estimates kept (NaN: none usable)
    std_s: float  # its 1-sigma: the formal one inflated by the Birge ratio when the estimates disagree
    n_used: int  # estimates kept
    n_rejected: int  # finite estimates dropped as outliers
    birge_ratio: float  # sqrt(chi^2 / (n - 1)) of the kept estimates about the mean (1 when n = 1)
    confidence: float  # P(|error| < tolerance) for a normal error of std_s: erf(tol / (sqrt(2) std))
    tolerance_s: float

    def usable(self, min_confidence: float) -> bool:
        return bool(np.isfinite(self.delay_s) and self.confidence >= min_confidence)


def combine_delays(delays, stds, tolerance_s: float = 0.005, outlier_sigma: float = 4.0) -> CombinedDelay:
    """One delay from several identifications with their formal sigmas (e.g. the same sweep flown
    with several seeds, and the lateral and longitudinal sweeps).

    1. Estimates that are not finite or have no positive sigma are dropped.
    2. Outliers: the robust centre is the weighted median m (weights 1/σ_i²) and the robust
       spread s = 1.4826 · median|τ_i − m| (MAD); τ_i is dropped when |τ_i − m| > ``outlier_sigma``
       · sqrt(σ_i² + s²) (a sweep whose coherent bins were not the sensor's: the phase slope of a
       track jump or of range noise, with a formal sigma far too small). Never more than half.
    3. τ = Σ τ_i/σ_i² / Σ 1/σ_i² over the kept ones, σ_f = (Σ 1/σ_i²)^−½; the Birge ratio
       R = sqrt(χ²/(n − 1)), χ² = Σ (τ_i − τ)²/σ_i², inflates it where the estimates scatter more
       than their formal sigmas say: σ = σ_f · max(1, R) (the coherence-based sigma of one sweep
       knows nothing of the seed-to-seed spread of the sweep itself).
    4. confidence = erf(tol / (√2 σ)): the probability that the combined delay is within
       ``tolerance_s`` of the truth.
    """
    d = np.asarray(delays, float).ravel()
    s = np.asarray(stds, float).ravel()
    if d.shape != s.shape:
        raise ValueError(f"delays and stds must have one length, got {d.size} and {s.size}")
    if not (np.isfinite(tolerance_s) and tolerance_s > 0):
        raise ValueError(f"tolerance_s must be > 0, got {tolerance_s}")
    ok = np.isfinite(d) & np.isfinite(s) & (s > 0)
    d, s = d[ok], s[ok]
    if d.size == 0:
        return CombinedDelay(math.nan, math.nan, 0, 0, math.nan, 0.0, float(tolerance_s))
    w = 1.0 / s**2
    order = np.argsort(d)
    cw = np.cumsum(w[order])
    m = float(d[order][np.searchsorted(cw, 0.5 * cw[-1])])  # weighted median
    mad = 1.4826 * float(np.median(np.abs(d - m)))
    z = np.abs(d - m) / np.sqrt(s**2 + mad**2)
    keep = z <= outlier_sigma
    if keep.sum() < max(1, math.ceil(d.size / 2)):  # never reject the majority: keep the half nearest m
        keep = z <= np.sort(z)[math.ceil(d.size / 2) - 1]
    dk, wk = d[keep], w[keep]
    tau = float(np.sum(wk * dk) / np.sum(wk))
    sf = float(1.0 / np.sqrt(np.sum(wk)))
    n = int(dk.size)
    birge = float(np.sqrt(np.sum(wk * (dk - tau) ** 2) / (n - 1))) if n > 1 else 1.0
    sigma = sf * max(1.0, birge)
    conf = float(math.erf(tolerance_s / (math.sqrt(2.0) * sigma)))
    return CombinedDelay(tau, sigma, n, int(d.size - n), birge, conf, float(tolerance_s))
