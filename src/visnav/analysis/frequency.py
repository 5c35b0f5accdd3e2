"""Frequency sweeps in closed loop: broken-loop response, stability margins, sensor delays.

Seed 000 §5.2: a logarithmic chirp is added to a cyclic actuator while the helicopter hovers on
MPE; the loop is broken at the actuator (injection e, applied x1 = u_c + e, controller output
x2 = u_c), so L(jω) = −X2/X1 (Tables 5.1, 5.2, Figs. 5.5, 5.6). Gain and phase margins come from
``control.stability_margins`` on the measured FRD. Sensor delays: ``delay_id``; the analytic loop:
``loop_model``; the campaigns of Tables 5.1/5.2: ``margins_campaign``.

Spectra (on a log-spaced grid): for a chirp, DFTs of the whole record with the cross-products
summed over a relative bandwidth; for stationary excitation, Welch/CSD estimates (``scipy.signal``)
over several window lengths combined per frequency with weights 2·n_d·γ²/(1 − γ²) (the inverse
random-error variance, γ² corrected for the bias of few averages: CIPHER's composite windows).
"""

from __future__ import annotations

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


