"""Metrics and the ch. 6 figures of the WITAS pad landing (seed 002 Figs. 6.5-6.11), from the log
(truth enters here, never the navigator).

Intervals: the *approach* runs from the first vision fix (filter start) to the last one before
touch-down. ``velocity_error_rms_mps``: 3-D filter velocity minus truth at the 10 Hz log instants of
the approach; ``vision_velocity_error_rms_mps``: the velocity from differencing consecutive raw
vision positions (frames 1/20 s apart) minus the mean true velocity over the pair. Attitude RMS:
roll and pitch pooled, filter at the log instants, vision at the frame instants of the approach.
``vision_lost_height_m``: true height of the skids at the last fix; ``blind_time_s``: from then to
touch-down. ``nees_mean``: mean of the 6-dof position-velocity NEES over the approach (6 if the
filter's covariance is consistent).
"""

from __future__ import annotations

import numpy as np

from visnav.analysis.metrics import finish_metrics, interp_rows
from visnav.analysis.metrics import final_mode
from visnav.analysis.report import _fig_to_img



def _pooled_rms_deg(e: np.ndarray) -> float:
    return float(np.degrees(np.sqrt(np.mean(e**2)))) if e.size else float("nan")


def approach_interval(log) -> tuple[float, float] | None:
    vis = log.get("pad_vision")
    if not vis:
        return None
    return float(vis["t"][0]), float(vis["t"][-1])


def vision_velocity(vis: dict, max_gap_s: float = 0.11) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(midpoint times, differentiated vision velocity (N, 3), index pairs) of consecutive fixes."""
    t, p = vis["t"], vis["position"]
    dt = np.diff(t)
    ok = (dt > 0) & (dt <= max_gap_s)
    v = np.diff(p, axis=0)[ok] / dt[ok, None]
    return 0.5 * (t[1:] + t[:-1])[ok], v, np.flatnonzero(ok)


def pad_metrics(log, scenario, *, wall_time_s: float, error: str | None = None) -> dict:
    tr, est = log.get("truth"), log.get("estimate")
    out: dict = {}
    sim_time = float(tr["t"][-1]) if tr else 0.0
    td = log.get("touchdown")
    out["landed"] = bool(td) and final_mode(log) == "landed" and not error
    iv = approach_interval(log)
    if td:
        p = td["position"][0]
        out["touchdown_error_m"] = float(np.hypot(p[0], p[1]))
        out["touchdown_speed_mps"] = float(td["speed"][0])
        out["position_error_at_touchdown_m"] = float(np.linalg.norm(est["position"][-1] - tr["position"][-1]))
    if iv is None or not tr:
        return finish_metrics(out, sim_time, wall_time_s, error or "no vision fix")
    vis, ft = log.get("pad_vision"), log.get("frame_truth")
    t_end = float(td["t"][0]) if td else sim_time
    out["vision_lost_height_m"] = float(-np.interp(iv[1], tr["t"], tr["position"][:, 2]))
    out["blind_time_s"] = float(t_end - iv[1])
    sel = (est["t"] >= iv[0]) & (est["t"] <= iv[1]) & est["valid"].astype(bool)
    ev = est["velocity"][sel] - tr["velocity"][sel]
    out["velocity_error_rms_mps"] = float(np.sqrt(np.mean(np.sum(ev**2, axis=1))))
    tm, vv, idx = vision_velocity(vis)
    tv = 0.5 * (interp_rows(vis["t"][idx], ft["t"], ft["velocity"]) + interp_rows(vis["t"][idx + 1], ft["t"],
                                                                                  ft["velocity"]))
    out["vision_velocity_error_rms_mps"] = float(np.sqrt(np.mean(np.sum((vv - tv) ** 2, axis=1)))) if len(vv) \
        else float("nan")
    ea = est["euler"][sel, :2] - tr["euler"][sel, :2]
    out["attitude_error_rms_deg"] = _pooled_rms_deg(ea)
    te = interp_rows(vis["t"], ft["t"], ft["euler"])
    evis = vis["euler"][:, :2] - te[:, :2]
    out["vision_attitude_error_rms_deg"] = _pooled_rms_deg(evis)
    out["vision_roll_bias_deg"], out["vision_pitch_bias_deg"] = (float(x) for x in np.degrees(evis.mean(axis=0)))
    dx = np.concatenate([est["position"][sel] - tr["position"][sel], ev], axis=1)
    cov = log.get("nav_cov")
    if cov:
        k = np.searchsorted(cov["t"], est["t"][sel])
        k = np.clip(k, 0, len(cov["t"]) - 1)
        same = np.abs(cov["t"][k] - est["t"][sel]) < 1e-6
        if same.any():
            pairs = zip(dx[same], cov["cov"][k[same]])
            out["nees_mean"] = float(np.mean([d @ np.linalg.solve(c, d) for d, c in pairs]))
    ep = vis["position"] - interp_rows(vis["t"], ft["t"], ft["position"])
    out["vision_position_error_rms_m"] = float(np.sqrt(np.mean(np.sum(ep**2, axis=1))))
    out["vision_fixes"] = int(len(vis["t"]))
    out["vision_rejected"] = int(np.sum(~vis["accepted"].astype(bool)))
    return finish_metrics(out, sim_time, wall_time_s, error)


def plots(log, sc=None) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    out = []
    tr, es, vis, ft = log.get("truth"), log.get("estimate"), log.get("pad_vision"), log.get("frame_truth")
    if not tr or not vis:
        return out
    v = es["valid"].astype(bool)
    names = ("north", "east", "down")
    # Fig. 6.5: filtered vs raw vision position
    fig, ax = plt.subplots(3, 1, figsize=(11, 7.5), sharex=True)
    for j in range(3):
        ax[j].plot(vis["t"], vis["position"][:, j], ".", ms=2, label="vision (raw)")
        ax[j].plot(es["t"][v], es["position"][v, j], "-", lw=1, label="filter")
        ax[j].set_ylabel(f"{names[j]} [m]")
    ax[0].legend(), ax[2].set_xlabel("t [s]")
    ax[0].set_title("Fig. 6.5: vision and filtered position")
    out.append(("Fig. 6.5 position", _fig_to_img(fig)))
    # Figs. 6.6-6.8: velocity from differentiated vision vs filter vs truth
    tm, vv, _ = vision_velocity(vis)
    for j, fig_no in zip(range(3), ("6.6", "6.7", "6.8")):
        fig, ax = plt.subplots(2, 1, figsize=(11, 5.5), sharex=True)
        ax[0].plot(tm, vv[:, j], "-", lw=0.7, color="tab:orange", label="differentiated vision")
        ax[0].plot(tr["t"], tr["velocity"][:, j], "k-", lw=1, label="truth")
        ax[1].plot(es["t"][v], es["velocity"][v, j], "-", lw=1, label="filter")
        ax[1].plot(tr["t"], tr["velocity"][:, j], "k--", lw=1, label="truth")
        for a in ax:
            a.set_ylabel(f"v {names[j]} [m/s]"), a.legend(loc="upper right")
        ax[0].set_title(f"Fig. {fig_no}: {names[j]} velocity")
        ax[1].set_xlabel("t [s]")
        out.append((f"Fig. {fig_no} {names[j]} velocity", _fig_to_img(fig)))
    # Figs. 6.9-6.10: roll and pitch from vision vs filter vs truth
    for j, (nm, fig_no) in enumerate((("roll", "6.9"), ("pitch", "6.10"))):
        fig, ax = plt.subplots(figsize=(11, 3.8))
        ax.plot(vis["t"], np.degrees(vis["euler"][:, j]), ".", ms=2, label="vision")
        ax.plot(es["t"][v], np.degrees(es["euler"][v, j]), "-", lw=1, label="filter")
        ax.plot(ft["t"], np.degrees(ft["euler"][:, j]), "k--", lw=0.8, label="truth")
        ax.set_ylabel(f"{nm} [deg]"), ax.set_xlabel("t [s]"), ax.legend()
        ax.set_title(f"Fig. {fig_no}: {nm} angle")
        out.append((f"Fig. {fig_no} {nm}", _fig_to_img(fig)))
    # Fig. 6.11: altitude with the vision loss / black-out marked
    fig, ax = plt.subplots(figsize=(11, 4))
    ax.plot(tr["t"], -tr["position"][:, 2], "k-", lw=1, label="truth")
    ax.plot(es["t"][v], -es["position"][v, 2], "-", lw=1, label="filter")
    ax.plot(vis["t"], -vis["position"][:, 2], ".", ms=2, label="vision")
    if ft and "blind" in ft and np.any(ft["blind"]):
        b = ft["t"][ft["blind"].astype(bool)]
        ax.axvspan(b[0], b[-1], color="#ffd0d0", label="black-out")
    ax.axvline(vis["t"][-1], color="r", lw=0.8, ls=":", label="last vision fix")
    ax.set_ylabel("height [m]"), ax.set_xlabel("t [s]"), ax.legend()
    ax.set_title("Fig. 6.11: altitude")
    out.append(("Fig. 6.11 altitude", _fig_to_img(fig)))
    return out
