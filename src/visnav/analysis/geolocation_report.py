"""Report of a geo-location flight (seed 002 ch. 7): the flight path over the map with the frames that
held the target (Fig. 7.7), the target samples of both methods around the true position (Figs. 7.8 and
7.10), the error of each sample and of the RLS estimate against the sample count (Figs. 7.9 and 7.11),
and the registrability map of the mission's map (beyond the thesis)."""

from __future__ import annotations

import numpy as np
from visnav.analysis.report import _fig_to_img
from visnav.world.rural import mission_map
from visnav.analysis.registrability import registrability_map



def plots(log, scenario=None) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    out = []
    smp, tgt = log.get("sample"), log.get("target")
    if not tgt:
        return out
    target = tgt["position"][0]
    geo = None
    if scenario is not None:
        geo = mission_map(scenario.world.geo_map)
    tr = log.get("truth")
    if tr and geo is not None:
        fig, ax = plt.subplots(figsize=(8, 8))
        n0, n1, e0, e1 = geo.extent_ned()
        ax.imshow(geo.image, cmap="gray", extent=[e0, e1, n0, n1])
        ax.plot(tr["position"][:, 1], tr["position"][:, 0], "c-", lw=1, label="flight path (truth)")
        fr = log.get("frame")
        if fr:
            v = fr["visible"].astype(bool)
            ax.plot(fr["position"][v, 1], fr["position"][v, 0], "y.", ms=3, label="frames showing the truck")
        ax.plot(target[1], target[0], "r*", ms=14, label="truck")
        ax.set_xlabel("east [m]")
        ax.set_ylabel("north [m]")
        ax.legend(loc="upper right", fontsize=8)
        ax.set_title("Figure-eight at 70 m over the truck (cf. Fig. 7.7)")
        out.append(("Flight path (Fig. 7.7)", _fig_to_img(fig)))
        plt.close(fig)
    if smp:
        ok = smp["ok"].astype(bool)
        reg = smp["reg"] - target
        mp = smp["map"] - target
        fig, ax = plt.subplots(1, 2, figsize=(13, 6))
        lim = max(10.0, float(np.nanpercentile(np.abs(np.r_[mp.ravel(), reg[ok].ravel()]), 95)) * 1.2)
        for a, d, title in ((ax[0], reg[ok], "registration (Fig. 7.8)"), (ax[1], mp, "map-based (Fig. 7.10)")):
            a.plot(d[:, 1], d[:, 0], "b.", ms=5, label="samples")
            est = smp["est_reg" if a is ax[0] else "est_map"] - target
            if np.isfinite(est[-1]).all():
                a.plot(est[-1, 1], est[-1, 0], "gs", ms=9, label="RLS estimate")
            a.plot(0, 0, "r*", ms=14, label="truck (truth)")
            a.set_xlim(-lim, lim)
            a.set_ylim(-lim, lim)
            a.set_aspect("equal")
            a.grid(True, alpha=0.3)
            a.set_xlabel("east error [m]")
            a.set_ylabel("north error [m]")
            a.set_title(title)
            a.legend(fontsize=8)
        out.append(("Target samples around the truth (Figs. 7.8, 7.10)", _fig_to_img(fig)))
        plt.close(fig)
        fig, ax = plt.subplots(2, 2, figsize=(13, 7), sharex="col")
        k = np.arange(1, len(ok) + 1)
        for col, key, est, title in ((0, "reg", "est_reg", "registration (Fig. 7.9)"),
                                     (1, "map", "est_map", "map-based (Fig. 7.11)")):
            e = np.linalg.norm(smp[key] - target, axis=1)
            ax[0, col].plot(k, e, "b.-", lw=0.5)
            ax[0, col].set_ylabel("sample error [m]")
            ax[0, col].set_title(title)
            ax[1, col].plot(k, np.linalg.norm(smp[est] - target, axis=1), "g-")
            ax[1, col].axhline(3.0, color="gray", ls=":", lw=1)
            ax[1, col].set_ylabel("RLS estimate error [m]")
            ax[1, col].set_xlabel("sample")
            for a in ax[:, col]:
                a.grid(True, alpha=0.3)
        fig.tight_layout()
        out.append(("Sample and RLS error vs sample count (Figs. 7.9, 7.11)", _fig_to_img(fig)))
        plt.close(fig)
    if geo is not None:
        try:
            m = scenario.world.geo_map  # scored under the appearance change this flight's reference had
            rq = registrability_map(geo, scenario.mission.altitude_m, unstable_m=m.change_m,
                                    texture_keep=m.change_keep, relief_level=m.relief_level,
                                    shift_m=m.relief_shift_m, shift_corr_m=m.relief_corr_m)
        except ValueError:
            rq = None
        if rq is not None:
            fig, ax = plt.subplots(figsize=(8, 8))
            n0, n1, e0, e1 = geo.extent_ned()
            ax.imshow(geo.image, cmap="gray", extent=[e0, e1, n0, n1])
            h, w = rq.score.shape
            ext = [rq.east0 - rq.cell_m / 2, rq.east0 + (w - 0.5) * rq.cell_m, rq.north0 - (h - 0.5) * rq.cell_m,
                   rq.north0 + rq.cell_m / 2]
            im = ax.imshow(rq.score, cmap="RdYlGn", alpha=0.55, extent=ext, vmin=0)
            fig.colorbar(im, ax=ax, fraction=0.046, label="registrability score")
            ax.plot(target[1], target[0], "b*", ms=12)
            ax.set_title(f"Registrability at {rq.altitude_m:.0f} m (beyond the thesis)")
            out.append(("Registrability map", _fig_to_img(fig)))
            plt.close(fig)
    return out
