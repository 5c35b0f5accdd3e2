"""Metrics and report plots of a PFCM flight (seed 002 ch. 4), from the flight log and truth.

The cross-track error is the distance of the true position to the path (Table 4.1 measured it on
the INS/GPS solution; truth is stricter). The VRS check compares the true descent rate with the
eq. 4.23 limit for the descent angle of the path at the closest point.
"""

from __future__ import annotations

import numpy as np

from visnav.analysis.metrics import finish_metrics
from visnav.guidance.speed_limits import descent_angle, max_descent_rate
from visnav.analysis.metrics import final_mode, mode_entered
from visnav.mission.pfcm import build_path
from visnav.analysis.report import _fig_to_img



#: ``vrs_margin_min_mps`` of a path that never descends (no eq. 4.23 limit applies), in the table and in JSON
NO_VRS_APPROACH = "no vortex-ring approach"


def notes(log, scenario, metrics: dict) -> list[str]:
    """Below the summary: by how much and how long the roll passed the planning bank limit phi_max (the turns
    are planned within it, eq. 4.15; the roll command may go phi_max + control.pfcm.roll_margin_deg for corrections in wind)."""
    tr = log.get("truth")
    m = scenario.mission
    if not tr or "euler" not in tr:
        return []
    sel = _follow_mask(log, np.asarray(tr["t"], float))
    roll = np.degrees(np.abs(np.asarray(tr["euler"], float)[sel, 0]))
    if not roll.size or roll.max() <= m.phi_max_deg:
        return []
    dt = float(np.median(np.diff(tr["t"]))) if len(tr["t"]) > 1 else 0.0
    return [f"max roll {roll.max():.1f} deg exceeds the bank limit phi_max {m.phi_max_deg:g} deg by "
            f"{roll.max() - m.phi_max_deg:.1f} deg, for {np.sum(roll > m.phi_max_deg) * dt:.1f} s of the "
            f"{roll.size * dt:.0f} s on the path: the turns are planned within phi_max (eq. 4.15), the roll command "
            f"may reach phi_max + roll_margin_deg = {m.phi_max_deg + scenario.control.pfcm.roll_margin_deg:g} deg to correct in wind"]


def _follow_mask(log, t: np.ndarray) -> np.ndarray:
    """Samples from the start of path following to its completion (or the end of the run)."""
    modes = log.get("mode")
    if not modes:
        return np.zeros(t.shape, bool)
    mt, mm = np.asarray(modes["t"]), list(modes["mode"])
    if "follow" not in mm:
        return np.zeros(t.shape, bool)
    t0 = mt[mm.index("follow")]
    after = [x for x, m in zip(mt, mm) if x > t0 and m != "follow"]
    t1 = after[0] if after else np.inf
    return (t >= t0) & (t <= t1)


def path_errors(path, truth: dict) -> dict[str, np.ndarray]:
    """Per truth sample: cross-track distance, arc position of the closest point, the descent-rate
    limit there (eq. 4.23) and the true descent rate."""
    d, l = path.closest(truth["position"])
    smp = path.sample(400)
    tau = smp["tangent"] / np.linalg.norm(smp["tangent"], axis=1, keepdims=True)
    gamma = np.interp(l, smp["l"], descent_angle(tau))
    return {"cross_track": d, "arc": l, "descent_limit": max_descent_rate(gamma),
            "descent": truth["velocity"][:, 2]}


def saturation_times(log) -> tuple[float, dict[str, float]]:
    """Time with at least one YACS channel saturated and per channel, summed over the path controller's
    updates (``pfcm_control``: its ``dt`` and ``sat_*`` flags) in the order it summed them."""
    c = log.get("pfcm_control")
    chans = ("ail", "ele", "rud", "thr")
    if not c:  # the controller never ran (no valid estimate): nothing saturated
        return 0.0, dict.fromkeys(chans, 0.0)
    if "dt" not in c:  # a log from before the controller logged its dt
        return float("nan"), {}
    total, per = 0.0, dict.fromkeys(chans, 0.0)
    flags = np.stack([np.asarray(c[f"sat_{k}"], bool) for k in chans], axis=1)
    for dt, row in zip(np.asarray(c["dt"], float), flags):
        if dt > 0:
            if row.any():
                total += float(dt)
            for k, f in zip(chans, row):
                per[k] += float(dt) if f else 0.0
    return total, per


def pfcm_metrics(log, scenario, *, wall_time_s: float, error: str | None = None) -> dict:
    """metrics.json of a PFCM run (issue #4 keys first), from the log and the scenario's path."""

    truth, ref = log.get("truth"), log.get("pfcm")
    sim_time = float(truth["t"][-1]) if truth else 0.0
    out: dict = {k: float("nan") for k in ("cross_track_rms_m", "cross_track_max_m", "speed_error_rms_mps",
                                           "max_roll_deg", "max_descent_mps")}
    sat, per = saturation_times(log)
    out["input_saturation_s"] = sat
    for c, v in per.items():
        out[f"{c}_saturation_s"] = float(v)
    # PfcmMission: path_completed <=> it entered "hold" (at t_complete); a touch-down is "crashed" (aborted)
    t_follow, t_complete = mode_entered(log, "follow"), mode_entered(log, "hold")
    aborted = mode_entered(log, "crashed") is not None
    out["path_completed"] = t_complete is not None and error is None and not aborted
    path = build_path(scenario.mission)
    if truth:
        sel = _follow_mask(log, truth["t"])
        if sel.any():
            e = path_errors(path, {k: truth[k][sel] for k in ("position", "velocity")})
            ct = e["cross_track"]
            out["cross_track_rms_m"] = float(np.sqrt(np.mean(ct**2)))
            out["cross_track_max_m"] = float(ct.max())
            out["max_descent_mps"] = float(max(e["descent"].max(), 0.0))
            over = e["descent"] - e["descent_limit"]
            dt = float(np.median(np.diff(truth["t"]))) if len(truth["t"]) > 1 else 0.0
            out["vrs_limit_exceeded_s"] = float(np.sum(over > 0) * dt)
            # eq. 4.23 limits the descent only on a descending path: a level or climbing one has no limit (inf)
            out["vrs_margin_min_mps"] = float(-over.max()) if np.isfinite(over.max()) else NO_VRS_APPROACH
            out["max_roll_deg"] = float(np.degrees(np.abs(truth["euler"][sel, 0]).max()))
            out["max_pitch_deg"] = float(np.degrees(np.abs(truth["euler"][sel, 1]).max()))
            out["max_speed_mps"] = float(np.linalg.norm(truth["velocity"][sel], axis=1).max())
        if ref:
            speed = np.linalg.norm(np.stack([np.interp(ref["t"], truth["t"], truth["velocity"][:, j])
                                             for j in range(3)], axis=1), axis=1)
            out["speed_error_rms_mps"] = float(np.sqrt(np.mean((speed - ref["v_target"]) ** 2)))
    out["path_length_m"] = float(path.length)
    out["flight_time_s"] = float((t_complete if t_complete is not None else sim_time) - (t_follow or 0.0))
    out["final_mode"] = final_mode(log)
    return finish_metrics(out, sim_time, wall_time_s, error)


# ------------------------------------------------------------------------------------ plots
def plots(log, scenario) -> list[tuple[str, str]]:
    """Report figures: path from above with the flown track, speed profile with the three limits,
    cross-track error, attitude and YACS inputs with saturation marks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    tr, ref = log.get("truth"), log.get("pfcm")
    cmd = log.get("pfcm_control") or log.get("command")  # 50 Hz outer-loop log if there is one
    if not tr:
        return []
    path = build_path(scenario.mission)
    smp = path.sample(100)
    out = []
    fig, ax = plt.subplots(1, 2, figsize=(12, 5), layout="constrained")
    ax[0].plot(smp["position"][:, 1], smp["position"][:, 0], "k--", lw=1, label="path")
    ax[0].plot(tr["position"][:, 1], tr["position"][:, 0], lw=1.2, label="flown (truth)")
    ax[0].plot(*path.start[[1, 0]], "go", label="A (start)"), ax[0].plot(*path.end[[1, 0]], "rs", label="B (end)")
    ax[0].set_xlabel("east [m]"), ax[0].set_ylabel("north [m]"), ax[0].axis("equal"), ax[0].legend()
    ax[0].set_title("Path from above")
    e = path_errors(path, tr)
    ax[1].plot(smp["l"], -smp["position"][:, 2], "k--", lw=1, label="path")
    ax[1].plot(e["arc"], -tr["position"][:, 2], lw=1.2, label="flown (truth)")
    ax[1].set_xlabel("distance along the path [m]"), ax[1].set_ylabel("height [m]"), ax[1].legend()
    ax[1].set_title("Height profile")
    out.append(("Path and flown track", _fig_to_img(fig)))

    if ref:
        t = ref["t"]
        fig, ax = plt.subplots(figsize=(12, 4.5), layout="constrained")
        cap = 1.5 * float(np.nanmax(ref["v_targ1"])) + 1.0
        ax.plot(t, np.minimum(ref["v_targ1"], cap), ":", label="v_targ1 (accelerate/cruise/brake)")
        ax.plot(t, np.minimum(ref["v_targ2"], cap), ":", label="v_targ2 (turn limits, eq. 4.15)")
        ax.plot(t, np.minimum(ref["v_targ3"], cap), ":", label="v_targ3 (VRS, eq. 4.23)")
        ax.plot(t, ref["v_target"], "k--", label="v_targ")
        ax.plot(tr["t"], np.linalg.norm(tr["velocity"], axis=1), label="ground speed (truth)")
        ax.set_ylim(0, cap), ax.set_xlabel("t [s]"), ax.set_ylabel("m/s"), ax.legend(loc="lower right")
        ax.set_title("Speed profile")
        out.append(("Speed profile", _fig_to_img(fig)))

    fig, ax = plt.subplots(2, 1, figsize=(12, 5.5), sharex=True, layout="constrained")
    sel = _follow_mask(log, tr["t"])
    ax[0].plot(tr["t"][sel], e["cross_track"][sel], label="distance to the path (truth)")
    if ref:
        ax[0].plot(ref["t"], ref["nav_cross_track"], "--", lw=0.8, label="to the control point (navigation)")
    ax[0].set_ylabel("m"), ax[0].legend(), ax[0].set_title("Cross-track error")
    ax[1].plot(tr["t"], -e["descent"], label="climb rate (truth)")
    ax[1].plot(tr["t"], -np.minimum(e["descent_limit"], 5.0), "r:", label="-(VRS descent limit)")
    ax[1].set_ylabel("m/s"), ax[1].set_xlabel("t [s]"), ax[1].legend()
    out.append(("Cross-track error and descent rate", _fig_to_img(fig)))

    fig, ax = plt.subplots(2, 1, figsize=(12, 6), sharex=True, layout="constrained")
    ax[0].plot(tr["t"], np.degrees(tr["euler"][:, 0]), label="roll")
    ax[0].plot(tr["t"], np.degrees(tr["euler"][:, 1]), label="pitch")
    phi = scenario.mission.phi_max_deg
    for s in (-1, 1):
        ax[0].axhline(s * phi, color="k", lw=0.5, ls=":")
    ax[0].set_ylabel("deg"), ax[0].legend(), ax[0].set_title("Attitude (truth), ±phi_max dotted")
    if cmd:
        for k in ("ail", "ele", "rud", "thr"):
            line, = ax[1].plot(cmd["t"], cmd[k], lw=0.9, label=k)
            sat = np.asarray(cmd.get(f"sat_{k}", np.abs(cmd[k]) >= 499.999), bool)
            if sat.any():
                ax[1].plot(cmd["t"][sat], cmd[k][sat], "x", color=line.get_color(), ms=5)
        ax[1].axhline(500, color="k", lw=0.5), ax[1].axhline(-500, color="k", lw=0.5)
    ax[1].set_ylabel("YACS units"), ax[1].set_xlabel("t [s]"), ax[1].legend(ncol=4, loc="best")
    ax[1].set_title("YACS inputs (x: saturated, at ±500 or at the command limit)")
    out.append(("Attitude and YACS inputs", _fig_to_img(fig)))
    return out
