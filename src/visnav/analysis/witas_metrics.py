"""Metrics and report plots of the WITAS homing mission (seed 002 §5.9.1, Figs. 5.17-5.20), from the log
and truth (truth enters here, never the navigator).

All errors are horizontal and counted from the instant the vision filter is engaged (GPS lost).
``odometry_drift_pct`` = final odometry-only error / distance flown x 100; ``returned_home``: the true
final position within ``home_radius_m`` (10 m) of home, the mission completed and not crashed.
"""

from __future__ import annotations

import numpy as np

from visnav.analysis.metrics import finish_metrics, interp_rows
from visnav.analysis.metrics import mode_entered
from visnav.analysis.report import _fig_to_img
from visnav.world.witas_map import make_ground



#: track colours that read on the grey map and on a white legend (white and yellow did not)
ODO_COLOR, INS_COLOR = "#d95f02", "darkviolet"


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def witas_metrics(log, scenario, *, wall_time_s: float, error: str | None = None) -> dict:
    cfg = scenario.mission
    tr, est = log.get("truth"), log.get("estimate")
    out: dict = {}
    sim_time = float(tr["t"][-1]) if tr else 0.0
    eng = log.get("vision_engaged")
    setup = log.get("witas_setup")
    home = np.asarray(setup["home"][0], float) if setup else np.full(3, np.nan)  # app/witas_parts.py logs it
    if not tr or not eng:
        out["returned_home"] = False
        return finish_metrics(out, sim_time, wall_time_s, error or "vision filter never engaged")
    t0 = float(eng["t"][0])
    tt, tp = tr["t"], tr["position"]
    sel = tt >= t0
    steps = np.linalg.norm(np.diff(tp[sel, :2], axis=0), axis=1)
    dist = float(steps.sum())
    out["path_length_m"] = dist
    pmf = log.get("pmf")
    if pmf:
        e = np.linalg.norm(pmf["position"] - interp_rows(pmf["t"], tt, tp)[:, :2], axis=1)
        out["pmf_error_max_m"] = float(e.max())
        out["pmf_error_rms_m"] = float(np.sqrt(np.mean(e**2)))
        out["pmf_sigma_max_m"] = float(np.sqrt(np.max(np.linalg.eigvalsh(pmf["cov"]))))
        out["registrations"] = int(np.sum(pmf["registered"]))
    odo = log.get("odometry")
    if odo:
        eo = np.linalg.norm(odo["position"][-1, :2] - interp_rows(odo["t"][-1], tt, tp)[0, :2])
        out["odometry_error_final_m"] = float(eo)
        out["odometry_drift_pct"] = float(100.0 * eo / dist) if dist > 0 else float("nan")
        out["odometry_skipped"] = int(np.sum(~np.asarray(odo["ok"], bool)))
        out["features_tracked_mean"] = float(np.mean(odo["n_tracked"]))
        out["ransac_outliers_mean"] = float(np.mean(odo["n_outliers"]))
    ins = log.get("ins_only")
    if ins:
        out["ins_only_error_final_m"] = float(np.linalg.norm(ins["position"][-1, :2]
                                                             - interp_rows(ins["t"][-1], tt, tp)[0, :2]))
    if est:
        es = est["t"] >= t0
        tv = interp_rows(est["t"][es], tt, tr["velocity"])
        ve = np.linalg.norm(est["velocity"][es, :2] - tv[:, :2], axis=1)
        out["velocity_error_rms_mps"] = float(np.sqrt(np.mean(ve**2)))
        pe = np.linalg.norm(est["position"][es, :2] - interp_rows(est["t"][es], tt, tp)[:, :2], axis=1)
        out["kf_error_max_m"] = float(pe.max())
        te = interp_rows(est["t"][es], tt, np.unwrap(tr["euler"], axis=0))
        ae = np.degrees(_wrap(est["euler"][es] - te))
        out["heading_error_final_deg"] = float(abs(ae[-1, 2]))
        out["roll_error_final_deg"] = float(abs(ae[-1, 0]))
        out["pitch_error_final_deg"] = float(abs(ae[-1, 1]))
    d_home = float(np.linalg.norm(tp[-1, :2] - home[:2]))
    out["home_error_m"] = d_home
    # PfcmMission: the path is completed when it enters "hold"; a touch-down is "crashed" (aborted)
    completed, crashed = mode_entered(log, "hold") is not None, mode_entered(log, "crashed") is not None
    out["returned_home"] = bool(d_home <= cfg.home_radius_m and completed and not crashed)
    return finish_metrics(out, sim_time, wall_time_s, error)


# ------------------------------------------------------------------------------------ plots
def plots(log, scenario) -> list[tuple[str, str]]:
    """Fig. 5.17 (map with tracks, PMF ellipses), 5.18 (position and velocity errors), 5.19 (attitude
    errors), 5.20 (features tracked, RANSAC outliers)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Ellipse


    tr, est, pmf, odo, ins = (log.get(k) for k in ("truth", "estimate", "pmf", "odometry", "ins_only"))
    if not tr:
        return []
    out = []
    fig, axs = plt.subplots(1, 2, figsize=(14, 7), layout="constrained")
    try:
        ground, _ = make_ground(scenario.mission.path, scenario.world.witas_map, scenario.run.seed, scenario.sensors.camera)
        n0, n1, e0, e1 = ground.extent_ned()
        img = ground.level(min(2, ground.max_level))
        for a in axs:
            a.imshow(img, cmap="gray", extent=(e0, e1, n0, n1), origin="upper")
    except (OSError, ValueError) as exc:  # the map is decoration: the tracks are drawn anyway
        axs[0].set_title(f"(reference map not drawn: {exc})", fontsize=8)
    tp = tr["position"]
    lim_e = (tp[:, 1].min() - 60, tp[:, 1].max() + 60)
    lim_n = (tp[:, 0].min() - 60, tp[:, 0].max() + 60)
    ax = axs[0]
    ax.plot(tp[:, 1], tp[:, 0], "b", lw=1.2, label="truth (GPS reference)")
    if pmf:
        ax.plot(pmf["position"][:, 1], pmf["position"][:, 0], "r", lw=1, label="PMF")
    if odo:
        ax.plot(odo["position"][:, 1], odo["position"][:, 0], "--", color=ODO_COLOR, lw=1.2, label="odometry only")
    if ins:
        ax.plot(ins["position"][:, 1], ins["position"][:, 0], ":", color=INS_COLOR, lw=1.2, label="INS only")
    ax.plot(tp[0, 1], tp[0, 0], "go", label="home")
    ax.set_xlim(*lim_e), ax.set_ylim(*lim_n), ax.set_xlabel("east [m]"), ax.set_ylabel("north [m]")
    ax.legend(loc="best", fontsize=8), ax.set_title("Tracks (Fig. 5.17 top)")
    ax = axs[1]
    ax.plot(tp[:, 1], tp[:, 0], "b", lw=0.8, label="truth (GPS reference)")
    if pmf:
        ax.plot(pmf["position"][:, 1], pmf["position"][:, 0], "r", lw=0.8, label="PMF")
        for k in range(0, len(pmf["t"]), max(1, len(pmf["t"]) // 60)):
            C = pmf["cov"][k]
            sn, se = np.sqrt(max(C[0, 0], 0)), np.sqrt(max(C[1, 1], 0))
            ax.add_patch(Ellipse((pmf["position"][k, 1], pmf["position"][k, 0]), 2 * 3 * se, 2 * 3 * sn,
                                 fill=False, color="orange", lw=0.8,
                                 label="PMF 3-sigma north/east ellipse" if k == 0 else None))
    ax.legend(loc="best", fontsize=8)  # issue #32: the panel had none
    ax.set_xlim(*lim_e), ax.set_ylim(*lim_n), ax.set_xlabel("east [m]")
    ax.set_title("PMF with 3-sigma north/east ellipses (Fig. 5.17 bottom)")
    out.append(("Map, tracks and PMF uncertainty", _fig_to_img(fig)))

    fig, ax = plt.subplots(2, 2, figsize=(14, 7), sharex=True, layout="constrained")
    tt = tr["t"]

    def herr(s):
        return np.linalg.norm(s["position"][:, :2] - interp_rows(s["t"], tt, tp)[:, :2], axis=1)

    if pmf:
        ax[1, 0].plot(pmf["t"], herr(pmf), "r", label="PMF")
        sig = np.sqrt(np.max(np.linalg.eigvalsh(pmf["cov"]), axis=1))
        ax[1, 0].plot(pmf["t"], 3 * sig, "r:", lw=0.8, label="PMF 3 sigma (max axis)")
    if odo:
        ax[1, 0].plot(odo["t"], herr(odo), "--", color=ODO_COLOR, label="odometry")
    if ins:
        ax[1, 0].plot(ins["t"], herr(ins), color=INS_COLOR, label="INS only")
    ax[1, 0].set_yscale("log"), ax[1, 0].set_ylim(0.05, None)
    ax[1, 0].set_ylabel("m (log)"), ax[1, 0].set_title("Horizontal position error")
    if ax[1, 0].get_legend_handles_labels()[0]:  # a short run has no PMF, odometry or INS track yet: no empty legend
        ax[1, 0].legend(fontsize=8)
    if est:
        tv = interp_rows(est["t"], tt, tr["velocity"])
        for j, name in ((0, "north"), (1, "east")):
            ax[0, j].plot(tt, tr["velocity"][:, j], "b", label="truth")
            ax[0, j].plot(est["t"], est["velocity"][:, j], "r", lw=0.8, label="filter")
            ax[0, j].set_title(f"{name} velocity [m/s]"), ax[0, j].legend(fontsize=8)
        ax[1, 1].plot(est["t"], np.linalg.norm(est["velocity"][:, :2] - tv[:, :2], axis=1), "r")
        ax[1, 1].set_title("Horizontal velocity error [m/s]")
    ax[1, 0].set_xlabel("t [s]"), ax[1, 1].set_xlabel("t [s]")
    out.append(("Position and velocity errors (Fig. 5.18)", _fig_to_img(fig)))

    if est:
        fig, ax = plt.subplots(3, 2, figsize=(14, 7.5), sharex=True, layout="constrained")
        te = interp_rows(est["t"], tt, np.unwrap(tr["euler"], axis=0))
        for j, name in enumerate(("roll", "pitch", "heading")):
            ax[j, 0].plot(tt, np.degrees(np.unwrap(tr["euler"][:, j])), "b", label="truth")
            ax[j, 0].plot(est["t"], np.degrees(np.unwrap(est["euler"][:, j])), "r", lw=0.8, label="filter")
            ax[j, 0].set_ylabel(f"{name} [deg]")
            ax[j, 1].plot(est["t"], np.degrees(_wrap(est["euler"][:, j] - te[:, j])), "r")
            ax[j, 1].set_ylabel(f"{name} error [deg]")
        ax[0, 0].legend(fontsize=8), ax[2, 0].set_xlabel("t [s]"), ax[2, 1].set_xlabel("t [s]")
        out.append(("Attitude and attitude errors (Fig. 5.19)", _fig_to_img(fig)))
    if odo:
        fig, ax = plt.subplots(figsize=(14, 4), layout="constrained")
        ax.plot(odo["t"], odo["n_tracked"], label="features tracked")
        ax.plot(odo["t"], odo["n_outliers"], label="RANSAC outliers")
        bad = ~np.asarray(odo["ok"], bool)
        if bad.any():
            ax.plot(odo["t"][bad], np.zeros(bad.sum()), "rx", label="odometry step skipped")
        ax.set_xlabel("t [s]"), ax.legend(), ax.set_title("Features and outliers (Fig. 5.20)")
        out.append(("Features tracked and RANSAC outliers (Fig. 5.20)", _fig_to_img(fig)))
    return out
