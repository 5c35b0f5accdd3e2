"""Self-contained HTML report of a run: plots inline as base64 PNG, metrics beside the seed's figures."""

from __future__ import annotations

import base64
import html
import importlib
import io
from pathlib import Path

import numpy as np

from visnav.analysis.metrics import interp_rows
from visnav.analysis.published import notes, published, summary_rows
from visnav.io.provenance import provenance as make_provenance, provenance_html
from visnav.analysis.outcome import verdict_line


def _fig_to_img(fig) -> str:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    plt.close(fig)
    return '<img src="data:image/png;base64,' + base64.b64encode(buf.getvalue()).decode() + '"/>'


#: background colour of each mission mode in the PALACE plots (modes not listed are left white)
MODE_COLORS = {"acquire": "#eeeeee", "descend_gps": "#dde8ff", "verify": "#ffe9c6", "hold": "#e2ffd8",
               "descend_mpe": "#d8ffe9", "final": "#f3d8ff", "abort": "#ffd0d0", "lost": "#ffd0d0"}


def _mode_spans(ax, log) -> list[str]:
    """Shade each mode's time span; returns the modes shaded, in order of first appearance."""
    modes = log.get("mode")
    if not modes:
        return []
    t = list(modes["t"]) + [np.inf]
    shown: list[str] = []
    for i, m in enumerate(modes["mode"]):
        if m in MODE_COLORS:
            ax.axvspan(t[i], min(t[i + 1], ax.get_xlim()[1]), color=MODE_COLORS[m], alpha=0.6, lw=0)
            shown += [] if m in shown else [m]
    return shown


def _mode_legend(fig, modes: list[str]) -> None:
    """A legend of the mode bands, above the axes (outside the data)."""
    from matplotlib.patches import Patch

    if modes:
        fig.legend([Patch(color=MODE_COLORS[m], alpha=0.6) for m in modes], [f"mode: {m}" for m in modes],
                   loc="outside upper center", ncol=min(len(modes), 6), fontsize=8, frameon=False)


def plots(log, point=None) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = []
    tr, es, rf = log.get("truth"), log.get("estimate"), log.get("reference")
    if not tr:
        return out
    t = tr["t"]
    # side view along the approach and top view
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5), layout="constrained")
    ax[0].plot(tr["position"][:, 0], -tr["position"][:, 2], label="truth")
    v = es["valid"].astype(bool)
    ax[0].plot(es["position"][v, 0], -es["position"][v, 2], "--", label="estimate")
    ax[0].plot(rf["position"][:, 0], -rf["position"][:, 2], ":", label="reference (white rabbit)")
    ax[0].set_xlabel("north [m]"), ax[0].set_ylabel("height AGL [m]"), ax[0].set_title("Side view")
    ax[0].legend()
    ax[1].plot(tr["position"][:, 1], tr["position"][:, 0], label="truth")
    ax[1].plot(es["position"][v, 1], es["position"][v, 0], "--", label="estimate")
    if point is not None:
        ax[1].plot(point[1], point[0], "r+", ms=14, label="designated point")
    ax[1].set_xlabel("east [m]"), ax[1].set_ylabel("north [m]"), ax[1].set_title("Top view")
    ax[1].axis("equal"), ax[1].legend()
    out.append(("Trajectory", _fig_to_img(fig)))

    mpe = log.get("mpe")
    fig, ax = plt.subplots(2, 1, figsize=(12, 6), sharex=True, layout="constrained")
    err = es["position"] - tr["position"]
    valid = es["valid"].astype(bool)
    ax[0].plot(t[valid], np.linalg.norm(err[valid, :2], axis=1), label="navigation estimate - truth (horizontal)")
    if mpe:
        me = mpe["position"] - interp_rows(mpe["t"], t, tr["position"])
        ax[0].plot(mpe["t"], np.linalg.norm(me[:, :2], axis=1), ".", ms=2, label="MPE fix - truth")
    ax[0].set_ylabel("error [m]"), ax[0].legend(loc="best"), ax[0].set_title("Position error")
    ax[1].plot(t, -tr["position"][:, 2], label="height AGL (truth)")
    ax[1].set_ylabel("m"), ax[1].set_xlabel("t [s]"), ax[1].legend(loc="best")
    shown = [_mode_spans(a, log) for a in ax][0]
    _mode_legend(fig, shown)
    out.append(("Errors and modes", _fig_to_img(fig)))

    trk = log.get("tracker")
    if trk:
        fig, ax = plt.subplots(2, 1, figsize=(12, 5.5), sharex=True, layout="constrained")
        ax[0].plot(trk["t"], trk["coherence"], ".", ms=2)
        ax[0].set_ylabel("coherence (eq. 2.3)"), ax[0].set_ylim(-0.1, 1.05)
        ax[1].plot(trk["t"], trk["x"], label="x"), ax[1].plot(trk["t"], trk["y"], label="y")
        ax[1].set_ylabel("tracked point [px]"), ax[1].set_xlabel("t [s]"), ax[1].legend()
        out.append(("Tracker", _fig_to_img(fig)))

    cmd = log.get("command")
    fig, ax = plt.subplots(2, 1, figsize=(12, 5.5), sharex=True, layout="constrained")
    ax[0].plot(t, np.rad2deg(tr["euler"][:, 0]), label="roll")
    ax[0].plot(t, np.rad2deg(tr["euler"][:, 1]), label="pitch")
    ax[0].set_ylabel("deg"), ax[0].legend(loc="best"), ax[0].set_title("Attitude (truth)")
    for k in ("ail", "ele", "rud", "thr"):
        ax[1].plot(cmd["t"], cmd[k], label=k)
    ax[1].axhline(500, color="k", lw=0.5), ax[1].axhline(-500, color="k", lw=0.5)
    ax[1].set_ylabel("YACS units"), ax[1].set_xlabel("t [s]"), ax[1].legend(loc="best", ncol=4)
    shown = [_mode_spans(a, log) for a in ax][0]
    _mode_legend(fig, shown)
    out.append(("Attitude and YACS commands", _fig_to_img(fig)))
    return out


#: mission type -> module with its own report: ``plots(log, scenario) -> [(title, img)]`` and optionally
#: ``notes(log, scenario, metrics) -> [str]``; other missions get the PALACE plots. The theses' figures
#: beside the metrics are in ``analysis/published.py``.
MISSION_REPORTS = {"pfcm": "visnav.analysis.path_metrics", "witas-homing": "visnav.analysis.witas_metrics",
                   "condor": "visnav.analysis.condor_report",
                   "deck": "visnav.analysis.deck_report",
                   "mav-geolocation": "visnav.analysis.geolocation_report", "pad-landing": "visnav.analysis.pad_report"}


def _report_module(sc):
    own = MISSION_REPORTS.get(getattr(sc.mission, "type", ""))
    return importlib.import_module(own) if own else None


def published_figures(sc) -> tuple[dict, str]:
    """(metric -> the thesis' figure with its conditions, which thesis) for a scenario's mission."""
    figs, source = published(sc)
    return {p.metric: p.figure for p in figs}, source


def published_bands(sc) -> dict[str, tuple[float, float]]:
    """metric -> the band its thesis figure is met inside (e.g. the deck NEES's 95 % chi2(12) band)."""
    return {p.metric: p.band for p in published(sc)[0] if p.band is not None}


def run_notes(result) -> list[str]:
    """Lines below the metrics table: what a run cannot measure, and what its log shows beyond the metrics."""
    mod = _report_module(result.scenario)
    extra = getattr(mod, "notes", None)
    sil = [f"SIL: {n}" for n in (result.metrics or {}).get("sil_notes", [])]  # one line each, not a list
    return notes(result.scenario) + (extra(result.log, result.scenario, result.metrics) if extra else []) + sil


def metrics_table_html(sc, metrics: dict) -> str:
    rows, omitted, source = summary_rows(sc, metrics)
    body = "".join(f"<tr><td>{html.escape(r.metric)}</td><td>{html.escape(r.ours)}</td>"
                   f"<td>{html.escape(r.thesis)}</td><td>{html.escape(r.verdict)}</td></tr>" for r in rows)
    head = f"<tr><th>metric</th><th>this run</th><th>thesis: {html.escape(source)}</th><th>verdict</th></tr>"
    skipped = (f"<p>Not applicable to this run: {html.escape(', '.join(omitted))}.</p>" if omitted else "")
    return f"<table>{head}{body}</table>{skipped}"


def headline_html(sc, metrics: dict) -> str:
    """The top of a report (issue #32: the verdict was a row near the bottom of a 33-row table): the outcome
    line, then the few metrics the thesis gives a bound for, with their verdicts."""

    rows, _, source = summary_rows(sc, metrics)
    scored = [r for r in rows if r.verdict.startswith(("meets", "does not meet"))]
    bad = "unsafe" in str(metrics.get("outcome")) or "HPL" in verdict_line(metrics)
    out = (f"<p style='font-size:1.2em;padding:6px;background:{'#ffe0e0' if bad else '#e8f4e8'}'>"
           f"<b>{html.escape(verdict_line(metrics))}</b></p>")
    if scored:
        out += (f"<table><tr><th>headline figure</th><th>this run</th><th>thesis: {html.escape(source)}</th>"
                "<th>verdict</th></tr>" + "".join(
                    f"<tr><td>{html.escape(r.metric)}</td><td>{html.escape(r.ours)}</td><td>{html.escape(r.thesis)}"
                    f"</td><td><b>{html.escape(r.verdict)}</b></td></tr>" for r in scored) + "</table>")
    return out


def write_report(result, path: Path, provenance: dict | None = None) -> None:
    """report.html of a run; ``provenance`` as written to metrics.json (made here when not given)."""
    sc, log, m = result.scenario, result.log, result.metrics
    prov = provenance_html(provenance if provenance is not None else make_provenance(sc))
    mod = _report_module(sc)
    if mod is not None:
        fig_list = mod.plots(log, sc)
    else:
        lp = getattr(sc.mission, "landing_point_m", None)
        fig_list = plots(log, None if lp is None else np.array(list(lp) + [0.0]))
    figs = "".join(f"<h2>{html.escape(title)}</h2>{img}" for title, img in fig_list)
    modes = log.get("mode")
    timeline = ""
    if modes:
        timeline = "<h2>Mission timeline</h2><table><tr><th>t [s]</th><th>mode</th><th>why</th></tr>" + "".join(
            f"<tr><td>{t:.1f}</td><td>{html.escape(str(a))}</td><td>{html.escape(str(r))}</td></tr>"
            for t, a, r in zip(modes["t"], modes["mode"], modes["reason"])
        ) + "</table>"
    err = f"<p style='color:#b00'><b>Run error:</b> {html.escape(result.error)}</p>" if result.error else ""
    note = "".join(f"<p>{html.escape(n)}</p>" for n in run_notes(result))
    doc = f"""<!doctype html><html><head><meta charset="utf-8"><title>visnav run: {html.escape(sc.run.name)}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto}} td,th{{padding:2px 10px;border-bottom:1px solid #ddd}}
img{{max-width:100%}}</style></head><body>
<h1>{html.escape(sc.run.name)} (seed {sc.run.seed})</h1><p>{html.escape(sc.run.description)}</p>{err}
{headline_html(sc, m)}
<h2>Metrics</h2>{metrics_table_html(sc, m)}{note}
{timeline}{figs}{prov}</body></html>"""
    Path(path).write_text(doc)
