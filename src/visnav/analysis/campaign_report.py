"""The HTML page of a Monte Carlo campaign (``report.html`` beside ``runs.csv`` and ``summary.json``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import base64
import html
import io
from visnav.analysis.outcome import outcome_text


def _as_number(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return None


def write_campaign_report(out: Path, rows: list[dict], summary: dict, grid_keys: list[str], scenario: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    ok = [r for r in rows if r.get("status") == "ok"]
    metrics = [k for k in summary.get("metrics", {}) if k not in ("sim_time_s",)][:12]
    imgs = []
    for k in metrics:
        fig, ax = plt.subplots(figsize=(6, 3.2))
        if grid_keys:
            g = grid_keys[0]
            labels = sorted({r.get(g) for r in ok}, key=lambda s: (_as_number(s) is None, _as_number(s) or 0, s))
            data = [[_as_number(r[k]) for r in ok if r.get(g) == lab and _as_number(r.get(k)) is not None]
                    for lab in labels]
            ax.boxplot([d if d else [np.nan] for d in data])
            ax.set_xticks(range(1, len(labels) + 1), labels)
            ax.set_xlabel(g)
        else:
            vals = [_as_number(r.get(k)) for r in ok]
            ax.hist([v for v in vals if v is not None and math.isfinite(v)], bins=20)
        ax.set_title(k)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=80, bbox_inches="tight")
        plt.close(fig)
        imgs.append('<img src="data:image/png;base64,' + base64.b64encode(buf.getvalue()).decode() + '"/>')
    table = "".join(
        f"<tr><td>{html.escape(k)}</td>" + "".join(f"<td>{v[s]:.4g}</td>" for s in ("mean", "median", "p95", "min", "max"))
        + f"<td>{v['n']}</td><td>{html.escape(str(v.get('published', '')))}</td></tr>"
        for k, v in summary.get("metrics", {}).items())
    rates = "".join(f"<tr><td>{html.escape(k)}</td><td>{v['rate']:.1%}</td><td>{v['count']} of {v['n']}</td>"
                    f"<td>{html.escape(str(v.get('published', '')))}</td></tr>"
                    for k, v in summary.get("rates", {}).items())
    bands = "".join(f"<p>{html.escape(k)}: {v['in_band']} of {v['n']} runs inside {v['band'][0]:g}-{v['band'][1]:g}</p>"
                    for k, v in summary.get("metrics", {}).items() if "in_band" in v)
    fails = "".join(f"<li>seed {html.escape(str(r.get('seed')))}: {html.escape(str(r.get('error')))}</li>"
                    for r in rows if r.get("status") != "ok")
    doc = f"""<!doctype html><html><head><meta charset="utf-8"><title>campaign {html.escape(scenario)}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto}} td,th{{padding:2px 8px;border-bottom:1px solid #ddd}}</style>
</head><body><h1>Campaign: {html.escape(scenario)}</h1><p><b>{html.escape(outcome_text(summary.get('outcomes', {})))}</b></p>
<p>{summary['count']} runs, {summary['failed']} failed.
Grid: {html.escape(', '.join(grid_keys) or 'none')}.</p>
<table><tr><th>metric</th><th>mean</th><th>median</th><th>p95</th><th>min</th><th>max</th><th>n</th>
<th>{html.escape(summary.get('published_source', 'thesis'))}</th></tr>{table}</table>{bands}
{('<h2>Rates</h2><table><tr><th>metric</th><th>rate</th><th>runs</th><th>thesis</th></tr>' + rates + '</table>') if rates else ''}
{('<h2>Failed runs</h2><ul>' + fails + '</ul>') if fails else ''}<h2>Plots</h2>{''.join(imgs)}</body></html>"""
    (out / "report.html").write_text(doc)
