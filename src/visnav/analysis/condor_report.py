"""Report figures of the CONDOR runs (seed 004): orbit tracks, radius vs time, the outer-loop
components of Figs. 7.6 / 7.12, bank / aileron / rudder (Figs. 7.7-7.9), the eq. 3.25 error maps
(Figs. 3.7-3.21) and the ground-test rows (Tables 4.1-4.2)."""

from __future__ import annotations

import math

import numpy as np
from visnav.vision.rectification import CameraGeometry
from visnav.vision.rectification_errors import error_maps
from visnav.analysis.report import _fig_to_img


def _error_map_figure(scenario):
    import matplotlib.pyplot as plt


    c = scenario.sensors.camera
    half_h = math.radians(c.hfov_deg) / 2
    geom = CameraGeometry(c.width_px, c.height_px, half_h, math.atan(math.tan(half_h) * c.height_px / c.width_px))
    names = [("h", "+1 m height"), ("tilt", "+1 deg tilt"), ("roll", "+1 deg roll"), ("X", "+1 px X"),
             ("Y", "+1 px Y"), ("total", "sum (eq. 3.25)")]
    fig, ax = plt.subplots(3, 6, figsize=(18, 7.5), sharex=True, sharey=True, layout="constrained")
    for i, tilt in enumerate((-20.0, -30.0, -40.0)):
        m = error_maps(geom, 100.0, tilt, 0.0, step_px=8, method=scenario.navigation.vision.method)
        ext = [m["X_px"].min(), m["X_px"].max(), m["Y_px"].min(), m["Y_px"].max()]
        for j, (k, label) in enumerate(names):
            z = m[k]
            lim = float(np.nanpercentile(np.abs(z), 95))  # the rows next to the horizon blow up
            im = ax[i, j].imshow(z, origin="lower", extent=ext, cmap="coolwarm", aspect="auto", vmin=-lim, vmax=lim)
            cb = fig.colorbar(im, ax=ax[i, j], fraction=0.046, format="%.3g")
            cb.ax.tick_params(labelsize=7)
            if i == 0:
                ax[i, j].set_title(label)
            if j == 0:
                ax[i, j].set_ylabel(f"tilt {tilt:.0f} deg\nY [px]")
            if i == 2:
                ax[i, j].set_xlabel("X [px]")
    fig.suptitle("Radius error [m] at 100 m AGL for one unit of each measurement error (eq. 3.25, "
                 "Figs. 3.7-3.21); blank: above the horizon")
    return fig


def bank_oscillation(log, cfg) -> dict:
    """The bank angle's swing on the vision orbit (from the switch plus the transition to the end) against
    the GPS loiter before it: min, max, 5-95 % range [deg], the dominant period [s] (peak of the spectrum
    of bank minus its mean) and the steady-turn bank atan(V^2 / (g R)) of the mean airspeed on the orbit."""
    tr, modes = log.get("truth"), log.get("mode")
    if not tr or not modes or "vision_orbit" not in list(modes["mode"]):
        return {}
    t0 = float(modes["t"][list(modes["mode"]).index("vision_orbit")])
    t, phi = tr["t"], np.degrees(tr["euler"][:, 0])
    on = t >= t0 + cfg.orbit.transition_s
    if on.sum() < 20:
        return {}
    x = phi[on] - phi[on].mean()
    dt = float(np.median(np.diff(t)))
    f = np.fft.rfftfreq(x.size, dt)
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size)))
    k = 1 + int(np.argmax(spec[1:]))
    loiter = (t < t0) & (t >= min(10.0, t0 / 2))
    v = float(np.mean(tr["airspeed"][on])) if "airspeed" in tr else float("nan")
    out = {"t_from_s": float(t[on][0]), "min_deg": float(phi[on].min()), "max_deg": float(phi[on].max()),
           "p5_deg": float(np.percentile(phi[on], 5)), "p95_deg": float(np.percentile(phi[on], 95)),
           "period_s": float(1.0 / f[k]),
           "steady_deg": float(np.degrees(np.arctan(v**2 / (9.80665 * cfg.orbit.radius_m))))}
    if loiter.any():
        out["loiter_p5_deg"] = float(np.percentile(phi[loiter], 5))
        out["loiter_p95_deg"] = float(np.percentile(phi[loiter], 95))
    return out


def notes(log, scenario, metrics) -> list[str]:
    """Flag the bank limit cycle of the vision orbit, measured in the log."""
    b = bank_oscillation(log, scenario.mission)
    if not b:
        return []
    line = (f"Bank limit cycle on the vision orbit: from t = {b['t_from_s']:.0f} s the bank swings between "
            f"{b['min_deg']:.1f} and {b['max_deg']:.1f} deg (5-95 %: {b['p5_deg']:.1f} to {b['p95_deg']:.1f} deg, "
            f"dominant period {b['period_s']:.1f} s) about a steady-turn bank of {b['steady_deg']:.1f} deg")
    if "loiter_p5_deg" in b:
        line += f"; on the GPS loiter before it {b['loiter_p5_deg']:.1f} to {b['loiter_p95_deg']:.1f} deg (5-95 %)"
    return [line + f". The radius holds, but the aircraft rolls through this range every ~{b['period_s']:.0f} s."]


def plots(log, scenario) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    cfg = scenario.mission
    out = []
    gt = log.get("ground_test")
    if gt:
        fig, ax = plt.subplots(figsize=(11, 4), layout="constrained")
        i = np.arange(len(gt["t"]))
        ax.bar(i - 0.27, gt["published_error_pct"], 0.27, label="thesis flight hardware (Tables 4.1-4.2)")
        ax.bar(i, gt["thesis_error_pct"], 0.27, label="thesis method, simulated")
        ax.bar(i + 0.27, gt["ours_error_pct"], 0.27, label="our calibration + 2-D roll, simulated")
        ax.set_xticks(i, [f"{a}/{b}" for a, b in zip(gt["table"], gt["row"])])
        ax.set_ylabel("relative radius error [%]"), ax.axhline(0, color="k", lw=0.5), ax.legend()
        out.append(("Ground test rows", _fig_to_img(fig)))
        out.append(("Error maps (eq. 3.25)", _fig_to_img(_error_map_figure(scenario))))
        return out
    tr, ctl, vis = log.get("truth"), log.get("control"), log.get("vision")
    if not tr:
        return out
    target = np.array([scenario.world.tent.north_m, scenario.world.tent.east_m])
    R_des = cfg.orbit.radius_m
    modes = np.asarray(ctl["mode"]) if ctl else np.array([])
    fig, ax = plt.subplots(figsize=(7.5, 7.5), layout="constrained")
    p = tr["position"]
    vis_mask = modes == "vision_orbit" if len(modes) == len(p) else np.zeros(len(p), bool)
    ax.plot(p[~vis_mask, 1], p[~vis_mask, 0], ".", ms=1.5, color="0.6", label="GPS loiter")
    ax.plot(p[vis_mask, 1], p[vis_mask, 0], ".", ms=1.5, color="C0", label="vision orbit (truth)")
    a = np.linspace(0, 2 * np.pi, 200)
    ax.plot(target[1] + R_des * np.sin(a), target[0] + R_des * np.cos(a), "k--", lw=1, label=f"desired {R_des:.0f} m")
    ax.plot(target[1], target[0], "bs", ms=8, label="tent")
    w = scenario.world
    if w.wind_speed_mps > 0:
        ang = math.radians(w.wind_from_deg) + math.pi
        ax.annotate("", xy=(target[1] + 40 * math.sin(ang), target[0] + 40 * math.cos(ang)),
                    xytext=(target[1], target[0]), arrowprops=dict(arrowstyle="->", color="r", lw=2))
        ax.text(target[1] + 45 * math.sin(ang), target[0] + 45 * math.cos(ang), f"wind {w.wind_speed_mps:.1f} m/s",
                color="r")
    ax.set_xlabel("east [m]"), ax.set_ylabel("north [m]"), ax.axis("equal"), ax.legend(loc="upper right")
    ax.set_title(f"Orbit over the field, controller '{scenario.control.condor.orbit.logic}' (cf. Figs. 6.1, 7.4, 7.10)")
    out.append(("Orbit track", _fig_to_img(fig)))

    fig, ax = plt.subplots(figsize=(12, 4), layout="constrained")
    r_true = np.hypot(p[:, 0] - target[0], p[:, 1] - target[1])
    if vis:
        ok = vis["valid"].astype(bool)
        ax.plot(vis["t"][ok], vis["radius"][ok], ".", ms=2, label="vision radius")
    ax.plot(tr["t"], r_true, label="true radius")
    ax.axhline(R_des, color="k", ls="--", lw=1, label="desired")
    ax.set_xlabel("t [s]"), ax.set_ylabel("radius [m]"), ax.legend(), ax.set_title("Radius (cf. Figs. 7.1, 7.5, 7.11)")
    out.append(("Radius vs time", _fig_to_img(fig)))
    if ctl:
        fig, ax = plt.subplots(3, 1, figsize=(12, 9), sharex=True, layout="constrained")
        t = ctl["t"]
        ax[0].plot(t, ctl["base"], label="base heading rate (eq. 5.2 / 7.1)")
        ax[0].plot(t, ctl["err"], label="heading-rate error (eq. 5.1)")
        ax[0].plot(t, ctl["psidot_ref"], "k", lw=1, label="sum (eq. 5.3)")
        ax[0].set_ylabel("rad/s"), ax[0].legend(), ax[0].set_title("Outer loop components (cf. Figs. 7.6, 7.12)")
        ax[1].plot(tr["t"], np.degrees(tr["euler"][:, 0]), label="bank (truth)")
        ax[1].plot(t, np.degrees(ctl["phi_ref"]), "--", label="bank reference (eq. 5.4)")
        b = bank_oscillation(log, cfg)
        if b:
            ax[1].axhspan(b["p5_deg"], b["p95_deg"], xmin=0, color="C3", alpha=0.08, lw=0,
                          label=f"limit cycle on the vision orbit: {b['p5_deg']:.0f} to {b['p95_deg']:.0f} deg (5-95 %)")
        ax[1].set_ylabel("deg"), ax[1].legend(loc="lower left", fontsize=8)
        ax[2].plot(t, np.degrees(ctl["aileron"]), label="aileron")
        ax[2].plot(t, np.degrees(ctl["rudder"]), label="rudder")
        ax[2].set_ylabel("deflection [deg]"), ax[2].set_xlabel("t [s]"), ax[2].legend()
        ax[2].set_title("Aileron and rudder (cf. Figs. 7.8-7.9, 7.13-7.14)")
        for a_ in ax:
            if cfg.orbit.switch_time_s < t[-1]:
                a_.axvline(cfg.orbit.switch_time_s, color="0.5", ls=":")
        out.append(("Controller", _fig_to_img(fig)))
    if vis:
        fig, ax = plt.subplots(figsize=(12, 3.5), layout="constrained")
        ax.plot(vis["t"], np.degrees(vis["tilt_error"]), label="camera AHRS tilt error")
        ax.plot(vis["t"], np.degrees(vis["roll_error"]), label="camera AHRS roll error")
        ax.plot(vis["t"], np.degrees(vis["cam_roll"]), label="camera roll (imperfect stabilisation)")
        ax.set_ylabel("deg"), ax.set_xlabel("t [s]"), ax.legend()
        out.append(("Gimbal attitude errors", _fig_to_img(fig)))
    out.append(("Error maps (eq. 3.25)", _fig_to_img(_error_map_figure(scenario))))
    return out
