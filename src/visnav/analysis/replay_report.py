"""report.html of a replay run: metrics, notes, the estimate against the reference (top view, side
view, position error over time, with the navigator's source shaded)."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from visnav.analysis.report import _fig_to_img


def _figures(log, frame: str = "") -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    es, tr = log.get("estimate"), log.get("truth")
    if not es:
        return []
    v = np.asarray(es["valid"], bool)
    p, t = np.asarray(es["position"], float)[v], np.asarray(es["t"], float)[v]
    out = []
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
    body = frame.startswith("deck-relative")  # the deck origin seen from the vehicle, body FRD: z is down
    up = 1.0 if body else -1.0
    if tr:
        q = np.asarray(tr["position"], float)
        ax[0].plot(q[:, 1], q[:, 0], label="reference")
        ax[1].plot(tr["t"], up * q[:, 2], label="reference")
    ax[0].plot(p[:, 1], p[:, 0], "--", label="estimate")
    ax[1].plot(t, up * p[:, 2], "--", label="estimate")
    if body:
        ax[0].set_xlabel("body y, right [m]"), ax[0].set_ylabel("body x, forward [m]")
        ax[0].set_title("Deck origin from the vehicle (body x-y)"), ax[0].axis("equal")
        ax[1].set_xlabel("t [s]"), ax[1].set_ylabel("body z, down [m]"), ax[1].set_title("Deck origin below the vehicle")
    else:
        ax[0].set_xlabel("east [m]"), ax[0].set_ylabel("north [m]"), ax[0].set_title("Top view"), ax[0].axis("equal")
        ax[1].set_xlabel("t [s]"), ax[1].set_ylabel("height [m]"), ax[1].set_title("Height")
    ax[0].legend(), ax[1].legend()
    out.append(("Trajectory", _fig_to_img(fig)))
    if tr and len(t):
        rt = np.asarray(tr["t"], float)
        ref = np.column_stack([np.interp(t, rt, np.asarray(tr["position"], float)[:, j]) for j in range(3)])
        err = p - ref
        fig, ax = plt.subplots(figsize=(12, 3.5))
        src = np.asarray(es["source"], dtype=object)[v]
        for s, c in zip(sorted(set(src)), ("#dde8ff", "#d8ffe9", "#ffe9c6", "#f3d8ff")):
            on = src == s
            ax.fill_between(t, 0, 1, where=on, color=c, alpha=0.7, transform=ax.get_xaxis_transform(), label=s)
        ax.plot(t, np.linalg.norm(err[:, :2], axis=1), label="horizontal")
        ax.plot(t, np.abs(err[:, 2]), label="vertical")
        ax.set_xlabel("t [s]"), ax.set_ylabel("|error| [m]"), ax.set_title("Position error against the reference")
        ax.legend(ncol=6, fontsize=8)
        out.append(("Error", _fig_to_img(fig)))
    return out


def write_replay_report(result, path: Path, title: str, verdict: str = "") -> None:
    rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{v:.4g}</td></tr>" if isinstance(v, float) else
                   f"<tr><td>{html.escape(k)}</td><td>{html.escape(str(v))}</td></tr>"
                   for k, v in result.metrics.items())
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in result.notes)
    figs = "".join(f"<h2>{html.escape(t)}</h2>{img}" for t, img in _figures(result.log, getattr(result, "frame", "") or ""))
    Path(path).write_text(f"""<!doctype html><html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto}} td{{padding:2px 10px;border-bottom:1px solid #ddd}}
img{{max-width:100%}} .verdict{{font-size:1.15em;font-weight:bold}}</style></head><body><h1>{html.escape(title)}</h1>
{f'<p class="verdict">{html.escape(verdict)}</p>' if verdict else ''}<p>frame: {html.escape(result.frame)}</p>
<h2>Metrics</h2><table>{rows}</table>{'<h2>Notes</h2><ul>' + notes + '</ul>' if notes else ''}{figs}</body></html>""")
