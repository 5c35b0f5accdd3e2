"""PALACE report pages (seed 000 ch. 4-5) from a drift campaign directory and a margins.csv.

Drift vs altitude per surface beside Figs. 4.2-4.4 and Table 4.1, MPE noise sigma vs altitude
against R/(f√12) plus laser noise, margin tables in the layout of Tables 5.1 and 5.2 beside the
thesis', and Bode plots of the measured broken-loop responses (``frf.npz`` of ``visnav margins``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from visnav.analysis.published import THESIS_TABLE_4_1  # noqa: F401  (re-exported)
from visnav.io.provenance import provenance, provenance_html
import csv
from visnav.analysis.noise import closed_form, mpe_error_series
from visnav.sensors.rangefinder import SURFACE_NOISE_FACTOR
import html
from visnav.analysis.report import _fig_to_img


# --------------------------------------------------------------------------- FRF storage
def _frf_name(key) -> str:
    alt, delay, comp, axis = key
    d = "gps" if delay is None else f"{float(delay):g}"
    return f"{float(alt):g}|{d}|{comp}|{axis}"


def save_frfs(path, frfs: dict) -> None:
    """Broken-loop responses keyed (altitude, delay or None, compensated, axis) to one ``.npz``."""
    arrays = {}
    for key, f in frfs.items():
        name = _frf_name(key)
        arrays[f"{name}|w"] = np.asarray(f["w"], float)
        arrays[f"{name}|H"] = np.asarray(f["H"], complex)
        arrays[f"{name}|coherence"] = np.asarray(f["coherence"], float)
    np.savez_compressed(path, **arrays)


def load_frfs(path) -> dict:
    """The inverse of ``save_frfs``: {(altitude, delay or None, compensated str, axis): {w, H, coherence}}."""
    out: dict = {}
    with np.load(path) as z:
        for name in z.files:
            alt, d, comp, axis, field = name.split("|")
            key = (float(alt), None if d == "gps" else float(d), comp, axis)
            out.setdefault(key, {})[field] = z[name]
    return out


# --------------------------------------------------------------------------- the thesis' numbers
#: Figs. 4.2/4.3 (simulation, 30 runs per point): mean and maximum drift per 120 s; Fig. 4.4 flight max
THESIS_DRIFT_PX = {"sim_mean": 20.0, "sim_max": 34.0, "flight_max": 22.8}
#: Table 5.1: (AGL m, delay s) -> (lat PM deg, wc, lat GM dB, w180, lon PM, wc, lon GM, w180)
THESIS_TABLE_5_1 = {
    (6, 0.0): (47.37, 2.81, 8.60, 8.83, 43.20, 2.65, 9.42, 8.26),
    (12, 0.0): (45.25, 2.60, 9.00, 8.94, 42.45, 2.53, 10.15, 8.39),
    (18, 0.0): (44.05, 2.65, 9.45, 9.10, 41.23, 2.67, 10.60, 8.49),
    (24, 0.0): (44.02, 2.59, 9.73, 9.18, 38.15, 2.53, 11.17, 8.61),
    (30, 0.0): (42.56, 2.54, 10.69, 9.59, 36.91, 2.31, 12.23, 9.48),
    (36, 0.0): (35.04, 2.47, 10.73, 9.62, 31.92, 2.32, 13.04, 9.31),
    (42, 0.0): (32.77, 2.53, 10.97, 9.65, 28.80, 2.39, 13.33, 9.63),
    (48, 0.0): (30.86, 2.46, 11.90, 10.22, 28.00, 2.28, 13.69, 10.17),
    (54, 0.0): (28.76, 2.19, 11.07, 9.68, 29.51, 2.35, 13.48, 9.47),
    (6, 0.1): (39.54, 2.31, 9.91, 9.92, 36.14, 2.37, 11.59, 9.57),
    (9, 0.1): (32.67, 2.29, 10.36, 10.44, 31.45, 2.29, 12.22, 10.21),
    (12, 0.1): (27.38, 2.27, 10.43, 11.05, 22.21, 2.15, 12.29, 10.88),
    (15, 0.1): (24.06, 2.22, 10.18, 11.38, 19.46, 2.16, 11.79, 11.32),
    (18, 0.1): (14.72, 2.17, 9.71, 11.65, 11.66, 2.20, 11.27, 11.76),
}
#: Table 5.2: case -> (lat PM, wc, lat GM, w180, lon PM, wc, lon GM, w180)
THESIS_TABLE_5_2 = {
    "Simulation using GPS": (45.84, 2.92, 8.37, 8.80, 44.39, 2.79, 8.86, 8.05),
    "GPS flight": (26.67, 3.21, 6.91, 6.24, 27.35, 2.73, 6.83, 5.65),
    "MPE flight w/o correction": (17.01, 2.63, 6.88, 4.09, 20.70, 2.54, 6.14, 3.98),
    "MPE flight w/43 ms correction": (38.50, 2.78, 8.53, 7.66, 32.68, 2.33, 7.96, 6.16),
}


# --------------------------------------------------------------------------- inputs
def _num(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def read_csv(path) -> list[dict]:
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"no such file: {p}")
    with p.open(newline="") as f:
        return list(csv.DictReader(f))


def drift_table(rows: list[dict]) -> list[dict]:
    """Per (surface, altitude, wind) of a ``palace-hover-drift`` campaign's runs.csv: n, mean and
    max drift [px], mean drift [m], lost tracks, mean σ [m] (Table 4.1's) and mean range [m]."""
    groups: dict = {}
    for r in rows:
        if r.get("status", "ok") != "ok":
            continue
        k = (r.get("surface", "?"), _num(r.get("altitude_m")), _num(r.get("world.wind_from_deg", math.nan)))
        groups.setdefault(k, []).append(r)
    out = []
    for (surf, alt, wind), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1], np.nan_to_num(kv[0][2]))):
        px = np.array([_num(r.get("drift_px")) for r in rs])
        px = px[np.isfinite(px)]
        if px.size == 0:
            continue
        out.append(dict(surface=surf, altitude_m=alt, wind_from_deg=wind, n=int(px.size), mean_px=float(px.mean()),
                        max_px=float(px.max()), mean_m=float(np.nanmean([_num(r.get("drift_m")) for r in rs])),
                        lost=sum(str(r.get("tracker_lost")) == "True" for r in rs),
                        sigma_m=float(np.nanmean([_num(r.get("mpe_noise_sigma_m")) for r in rs])),
                        range_m=float(np.nanmean([_num(r.get("mean_range_m")) for r in rs]))))
    return out


def drift_summary(table: list[dict]) -> dict:
    """The thesis' aggregates per surface: mean of the means and mean of the per-condition maxima
    (Figs. 4.2/4.3 average 30 runs' maxima per point), and the overall maximum."""
    out = {}
    for surf in sorted({r["surface"] for r in table}):
        t = [r for r in table if r["surface"] == surf]
        n = sum(r["n"] for r in t)
        out[surf] = dict(n=n, mean_px=float(sum(r["mean_px"] * r["n"] for r in t) / n),
                         mean_of_max_px=float(np.mean([r["max_px"] for r in t])),
                         max_px=float(max(r["max_px"] for r in t)))
    return out


def _at(v, w) -> str:
    v, w = _num(v), _num(w)
    if not math.isfinite(v):  # NaN: the sweep did not complete; inf: no crossover among coherent points
        return "n/a (sweep lost)" if math.isnan(v) else "no crossover found"
    return f"{v:.2f} at {w:.2f}" if math.isfinite(w) else f"{v:.2f}"


def _margin_cells(r: dict) -> list[str]:
    return [_at(r.get(f"{ax}_{m}"), r.get(f"{ax}_{m.split('_')[0]}_wc_rps"))
            for ax in ("lateral", "longitudinal") for m in ("pm_deg", "gm_db")]


def _thesis_cells(t) -> list[str]:
    return ["" if t is None else f"{t[i]:.2f} at {t[i + 1]:.2f}" for i in (0, 2, 4, 6)]


def table_5_1_rows(margins: list[dict]) -> list[list[str]]:
    """Table 5.1's layout (AGL, delay, lateral PM, lateral GM, longitudinal PM, longitudinal GM),
    ours on one line and the thesis' (where it has that altitude and delay) on the next."""
    out = []
    for r in margins:
        if str(r.get("compensated")) != "False":
            continue
        alt, d = _num(r["altitude_m"]), _num(r["delay_s"])
        t = THESIS_TABLE_5_1.get((int(round(alt)), round(d, 3)))
        out.append([f"{alt:g} m", f"{d * 1e3:.0f} ms", "ours", *_margin_cells(r)])
        out.append(["", "", "thesis", *_thesis_cells(t)])
    return out


def table_5_2_rows(margins: list[dict]) -> list[list[str]]:
    """Table 5.2's layout per altitude and delay: GPS, MPE without and with the identified correction."""
    out = []
    by = {(_num(r["altitude_m"]), str(r.get("compensated")), _num(r.get("delay_s"))): r for r in margins}
    for alt in sorted({_num(r["altitude_m"]) for r in margins}):
        gps = next((r for (a, c, _), r in by.items() if a == alt and c == "gps"), None)
        for d in sorted({k[2] for k in by if k[0] == alt and k[1] == "True"}):
            for name, r in (("GPS", gps), (f"MPE, IMU {d * 1e3:.0f} ms late, w/o correction", by.get((alt, "False", d))),
                            ("MPE w/ identified correction", by.get((alt, "True", d)))):
                if r is None:
                    continue
                ident = ""
                if name.startswith("MPE w/"):
                    ident = (f"IMU {_num(r.get('identified_imu_delay_s')) * 1e3:.1f} ms, "
                             f"laser {_num(r.get('identified_laser_delay_s')) * 1e3:.1f} ms")
                out.append([f"{alt:g} m", name, *_margin_cells(r), ident])
    for name, t in THESIS_TABLE_5_2.items():
        out.append(["thesis", name, *_thesis_cells(t), "43 ms" if "43" in name else ""])
    return out


# --------------------------------------------------------------------------- figures
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def drift_figure(table: list[dict]):
    plt = _plt()
    surfaces = sorted({r["surface"] for r in table})
    fig, axs = plt.subplots(1, max(1, len(surfaces)), figsize=(5 * max(1, len(surfaces)), 3.8), sharey=True,
                            squeeze=False)
    for ax, surf in zip(axs[0], surfaces):
        for wind, mk in ((0.0, "o"), (90.0, "s")):
            t = [r for r in table if r["surface"] == surf and r["wind_from_deg"] == wind]
            if t:
                ax.plot([r["altitude_m"] for r in t], [r["mean_px"] for r in t], mk + "-", label=f"ours mean, wind {wind:g}°")
                ax.plot([r["altitude_m"] for r in t], [r["max_px"] for r in t], mk + "--", mfc="none",
                        label=f"ours max, wind {wind:g}°")
        fl = [row for row in THESIS_TABLE_4_1 if row[1] == surf]
        if fl:
            ax.plot([row[0] for row in fl], [row[5] for row in fl], "k*", ms=9, label="thesis flight (Table 4.1)")
        ax.axhline(THESIS_DRIFT_PX["sim_mean"], color="g", ls=":", label="thesis sim mean 20 px (Fig. 4.2)")
        ax.axhline(THESIS_DRIFT_PX["sim_max"], color="r", ls=":", label="thesis sim max 34 px (Fig. 4.3)")
        ax.set_title(f"drift per 120 s over {surf}")
        ax.set_xlabel("altitude AGL [m]")
    axs[0][0].set_ylabel("equivalent drift [px]")
    axs[0][-1].legend(fontsize=7)
    return fig


def noise_figure(table: list[dict], focal_px: float, depression_deg: float = 60.0):
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4))
    rr = np.linspace(2.0, 70.0, 60)
    ax.plot(rr, rr / (focal_px * math.sqrt(12)), "k-", label="R/(f√12) (eq. 3.3)")
    for surf in sorted({r["surface"] for r in table}):
        t = [r for r in table if r["surface"] == surf]
        line = ax.plot([r["range_m"] for r in t], [r["sigma_m"] for r in t], "o", label=f"ours σ (§4.2.1 fit), {surf}")
        cf = closed_form(rr, focal_px, depression_deg, surface_factor=SURFACE_NOISE_FACTOR.get(surf, 1.0))
        ax.plot(rr, cf.sigma_horizontal_m, "--", color=line[0].get_color(), label=f"eq. 3.3 ⊕ laser (Fig. 3.4), {surf}")

    res, _ = mpe_error_series([8.0, 16.0, 32.0, 64.0], focal_px, depression_deg, n=300, surface_factor=1.5)
    ax.plot(res.range_m, res.sigma_horizontal_m, "kx", ms=9, label="open-loop MPE, integer pixels + laser (asphalt)")
    ax.plot(res.range_m, res.sigma_across_m, "k+", ms=9, label="same, across track only: slope 1/(f√12)")
    s60 = math.sin(math.radians(depression_deg))
    ax.plot([row[0] / s60 for row in THESIS_TABLE_4_1], [row[4] for row in THESIS_TABLE_4_1], "k*",
            label="thesis flight σ (Table 4.1)")
    ax.set_xlabel("slant range R [m]"), ax.set_ylabel("MPE noise σ [m]")
    ax.legend(fontsize=7)
    return fig


def margins_figure(margins: list[dict]):
    plt = _plt()
    fig, axs = plt.subplots(2, 2, figsize=(11, 6.5), sharex=True)
    cases = [("gps", None, "GPS", "k-o"), ("False", 0.0, "MPE 0 ms", "b-o"), ("False", 0.1, "MPE 100 ms", "r-o"),
             ("True", 0.0, "MPE 0 ms, identified comp.", "b--s"), ("True", 0.1, "MPE 100 ms, identified comp.", "r--s")]
    for j, ax_name in enumerate(("lateral", "longitudinal")):
        for i, (m, lab) in enumerate((("pm_deg", "phase margin [°]"), ("gm_db", "gain margin [dB]"))):
            ax = axs[i][j]
            for comp, d, name, style in cases:
                t = [r for r in margins if str(r.get("compensated")) == comp
                     and (d is None or abs(_num(r.get("delay_s")) - d) < 1e-9)]
                if t:
                    ax.plot([_num(r["altitude_m"]) for r in t], [_num(r[f"{ax_name}_{m}"]) for r in t], style,
                            label=name, ms=4)
            for d, style in ((0.0, "b:"), (0.1, "r:")):
                th = sorted((a, v) for (a, dd), v in THESIS_TABLE_5_1.items() if dd == d)
                k = (0 if ax_name == "lateral" else 4) + (0 if m == "pm_deg" else 2)
                ax.plot([a for a, _ in th], [v[k] for _, v in th], style, label=f"thesis {d * 1e3:.0f} ms (Table 5.1)")
            ax.set_ylabel(lab), ax.set_title(ax_name)
            if i == 1:
                ax.set_xlabel("altitude AGL [m]")
    axs[0][0].legend(fontsize=7)
    return fig


def bode_figure(frfs: dict, altitude_m: float, min_coherence: float = 0.6):
    """Measured broken-loop responses at one altitude (points below ``min_coherence`` faded)."""
    plt = _plt()
    fig, axs = plt.subplots(2, 2, figsize=(11, 6), sharex=True)
    for (alt, d, comp, axis), f in sorted(frfs.items(), key=lambda kv: str(kv[0])):
        if abs(alt - altitude_m) > 1e-9:
            continue
        j = 0 if axis == "lateral" else 1
        name = "GPS" if comp == "gps" else f"MPE {d * 1e3:.0f} ms" + (", comp." if comp == "True" else "")
        w, H, g = f["w"], f["H"], np.nan_to_num(f["coherence"])
        mag, ph = 20 * np.log10(np.abs(H)), np.degrees(np.unwrap(np.angle(H)))
        ph -= 360.0 * np.round(ph[0] / 360.0)
        ok = g >= min_coherence
        line = axs[0][j].semilogx(w, np.where(ok, mag, np.nan), label=name)
        axs[0][j].semilogx(w, mag, color=line[0].get_color(), alpha=0.25)
        axs[1][j].semilogx(w, np.where(ok, ph, np.nan), color=line[0].get_color())
        axs[1][j].semilogx(w, ph, color=line[0].get_color(), alpha=0.25)
        axs[0][j].set_title(f"{axis}, {altitude_m:g} m AGL")
    for j in range(2):
        axs[0][j].axhline(0, color="k", lw=0.5), axs[1][j].axhline(-180, color="k", lw=0.5)
        axs[1][j].set_xlabel("ω [rad/s]")
    axs[0][0].set_ylabel("|L| [dB]"), axs[1][0].set_ylabel("∠L [°]")
    axs[0][0].legend(fontsize=7)
    return fig


# --------------------------------------------------------------------------- the page
def _html_table(header: list[str], rows: list[list[str]]) -> str:
    h = "".join(f"<th>{html.escape(c)}</th>" for c in header)
    b = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{h}</tr>{b}</table>"


def write_palace_report(out_html, drift_dirs=(), margins_path=None, focal_px: float = 1073.0) -> Path:
    """One HTML page from ``palace-hover-drift`` campaign directories (their runs.csv) and a
    ``visnav margins`` output (its directory or margins.csv; frf.npz beside it for Bode plots)."""

    drift_rows = []
    for d in drift_dirs:
        p = Path(d)
        drift_rows += read_csv(p / "runs.csv" if p.is_dir() else p)
    margins, frfs = [], {}
    if margins_path is not None:
        p = Path(margins_path)
        csv_path = p / "margins.csv" if p.is_dir() else p
        margins = read_csv(csv_path)
        if (csv_path.parent / "frf.npz").is_file():
            frfs = load_frfs(csv_path.parent / "frf.npz")
    if not drift_rows and not margins:
        raise ValueError("nothing to report: give a drift campaign directory and/or a margins.csv")
    parts = []
    if drift_rows:
        table = drift_table(drift_rows)
        summ = drift_summary(table)
        parts.append("<h2>Tracker drift per 120 s (§4.2, Figs. 4.2-4.4, Table 4.1)</h2>")
        parts.append(f"<p>Thesis: simulation {THESIS_DRIFT_PX['sim_mean']:g} px mean, {THESIS_DRIFT_PX['sim_max']:g} px "
                     f"max (mean of the per-condition maxima); flight max {THESIS_DRIFT_PX['flight_max']:g} px.</p>")
        parts.append(_html_table(["surface", "runs", "mean px", "mean of per-condition max px", "max px"],
                                 [[s, v["n"], f"{v['mean_px']:.2f}", f"{v['mean_of_max_px']:.2f}", f"{v['max_px']:.2f}"]
                                  for s, v in summ.items()]))
        parts.append(_html_table(["surface", "AGL m", "wind from °", "n", "mean px", "max px", "mean m", "lost",
                                  "σ m", "range m"],
                                 [[r["surface"], f"{r['altitude_m']:g}", f"{r['wind_from_deg']:g}", r["n"],
                                   f"{r['mean_px']:.2f}", f"{r['max_px']:.2f}", f"{r['mean_m']:.3f}", r["lost"],
                                   f"{r['sigma_m']:.3f}", f"{r['range_m']:.1f}"] for r in table]))
        parts.append(_fig_to_img(drift_figure(table)))
        parts.append("<h3>Thesis Table 4.1 (flight)</h3>")
        parts.append(_html_table(["AGL m", "surface", "time s", "drift m", "σ m", "equiv. px"],
                                 [list(map(str, row)) for row in THESIS_TABLE_4_1]))
        parts.append("<h2>MPE noise σ against range (eq. 3.3 plus laser noise, Figs. 3.4, 4.5-4.7)</h2>")
        parts.append("<p>Circles: the campaign's σ about the §4.2.1 drift line (it also holds the tracker's random "
                     "walk within the 120 s and the IMU's attitude noise times R). Crosses: the open-loop MPE "
                     "error series of <code>analysis.noise</code> (integer pixels, laser noise of Fig. 3.4), "
                     "on the closed form.</p>")
        parts.append(_fig_to_img(noise_figure(table, focal_px)))
    if margins:
        hdr = ["AGL", "delay", "", "lateral PM ° at rad/s", "lateral GM dB at rad/s", "longitudinal PM",
               "longitudinal GM"]
        parts.append("<h2>Stability margins, layout of Table 5.1 (MPE, IMU delay uncompensated)</h2>")
        parts.append(_html_table(hdr, table_5_1_rows(margins)))
        parts.append("<h2>Layout of Table 5.2 (GPS; MPE without and with the identified correction)</h2>")
        parts.append(_html_table(["AGL", "case", "lateral PM", "lateral GM", "longitudinal PM", "longitudinal GM",
                                  "identified delays (behind the camera)"], table_5_2_rows(margins)))
        parts.append(_fig_to_img(margins_figure(margins)))
        notes = [(r["altitude_m"], r.get("delay_s") or "gps", r.get("compensated"), r.get("notes"))
                 for r in margins if r.get("notes")]
        if notes:
            parts.append("<h3>Notes</h3>" + _html_table(["AGL", "delay", "compensated", "notes"], notes))
        for alt in sorted({k[0] for k in frfs}):
            parts.append(f"<h2>Bode plots at {alt:g} m (broken loop at the actuator)</h2>")
            parts.append(_fig_to_img(bode_figure(frfs, alt)))

    doc = ("<!doctype html><html><head><meta charset='utf-8'><title>PALACE analysis (seed 000)</title>"
           "<style>body{font-family:sans-serif;max-width:1250px;margin:auto} td,th{padding:2px 8px;"
           "border-bottom:1px solid #ddd;font-size:13px} img{max-width:100%}</style></head><body>"
           "<h1>PALACE analysis suite (seed 000 ch. 4-5)</h1>" + "".join(parts)
           + provenance_html(provenance()) + "</body></html>")
    out = Path(out_html)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(doc)
    return out
