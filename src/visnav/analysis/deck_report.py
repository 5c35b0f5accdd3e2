"""Report of a deck landing run: estimate vs truth with +-2 sigma (seed 003 Figs. 5.12-5.17), error norms
against distance to the deck in 1 cm bins (Figs. 5.9-5.11, 5.19-5.21) and the flown paths (Figs. 5.8, 5.18)."""

from __future__ import annotations

import numpy as np

from visnav.analysis.deck_metrics import attitude_error_deg
from visnav.geometry.rotations import euler_to_dcm
from visnav.analysis.report import _fig_to_img

STATE_GROUPS = (("position", "relative position [m]", ("x", "y", "z"), 1.0),
                ("euler", "relative attitude [deg]", ("roll", "pitch", "yaw"), np.degrees(1.0)),
                ("velocity", "relative velocity [m/s]", ("u", "v", "w"), 1.0),
                ("deck_rates", "deck body rates [deg/s]", ("p", "q", "r"), np.degrees(1.0)))


def distance_and_errors(log) -> dict:
    """Distance from the vehicle body origin to the deck origin, and the error norms of the four state groups."""
    tr, es = log.get("truth"), log.get("estimate")
    if not tr:
        return {}
    d = np.linalg.norm(tr["position"], axis=1)
    return {"distance": d,
            "position": np.linalg.norm(es["position"] - tr["position"], axis=1),
            "attitude": np.radians(attitude_error_deg(tr["euler"], es["euler"])),
            "velocity": np.linalg.norm(es["velocity"] - tr["velocity"], axis=1),
            "deck_rates": np.linalg.norm(es["deck_rates"] - tr["deck_rates"], axis=1),
            "approach": np.isin(es["mode"], ["approach", "descend"])}


def binned_mean(distance: np.ndarray, value: np.ndarray, width: float = 0.01):
    """Mean of ``value`` in bins of ``width`` metres of ``distance`` (the black lines of Figs. 5.9-5.11)."""
    if distance.size == 0:
        return np.zeros(0), np.zeros(0)
    idx = np.floor(distance / width).astype(int)
    n = np.bincount(idx)
    s = np.bincount(idx, weights=value)
    ok = n > 0
    return (np.nonzero(ok)[0] + 0.5) * width, s[ok] / n[ok]


def relative_path(log) -> np.ndarray:
    """Vehicle position relative to the deck origin in the deck frame (N, 3)."""
    veh, dk = log.get("vehicle"), log.get("deck")
    C = euler_to_dcm(dk["euler"])
    return np.einsum("nji,nj->ni", C, veh["position"] - dk["position"])


def plots(log, scenario=None) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    out = []
    tr, es = log.get("truth"), log.get("estimate")
    if not tr:
        return out
    t = tr["t"]
    for key, title, names, scale in STATE_GROUPS:
        # left: estimate and truth (they overlap to the eye); right: their difference with the filter's +-2 sigma
        fig, ax = plt.subplots(3, 2, figsize=(12, 6.5), sharex=True, layout="constrained")
        j0 = {"position": 0, "euler": 3, "velocity": 6, "deck_rates": 9}[key]
        unit = title[title.index("[") + 1:-1]
        for i in range(3):
            sig = es["sigma"][:, j0 + i] * scale
            err = (es[key][:, i] - tr[key][:, i]) * scale
            if key == "euler":
                err = np.degrees((np.radians(err) + np.pi) % (2 * np.pi) - np.pi)
            ax[i, 0].plot(t, tr[key][:, i] * scale, lw=1.6, color="C1", label="truth")
            ax[i, 0].plot(t, es[key][:, i] * scale, lw=0.8, color="C0", label="estimate")
            ax[i, 0].set_ylabel(f"{names[i]} [{unit}]")
            ax[i, 1].plot(t, err, lw=0.8, color="C2", label="estimate - truth")
            ax[i, 1].fill_between(t, -2 * sig, 2 * sig, color="0.85", lw=0, label="+-2 sigma (filter)")
            ax[i, 1].set_ylabel(f"{names[i]} error [{unit}]")
            # scale to the error and the typical band, not to the start-up sigma (which would flatten the error)
            lim = 1.2 * max(np.nanpercentile(np.abs(err), 99), np.nanpercentile(2 * sig, 50), 1e-9)
            ax[i, 1].set_ylim(-lim, lim)
        ax[0, 0].set_title(f"Estimated {title} of the deck in the vehicle frame")
        ax[0, 1].set_title("Estimate error")
        handles = [h for a in (ax[0, 0], ax[0, 1]) for h in a.get_legend_handles_labels()[0]]
        fig.legend(handles, [h.get_label() for h in handles], loc="outside lower center", ncol=4, fontsize=8,
                   frameon=False)
        ax[2, 0].set_xlabel("t [s]"), ax[2, 1].set_xlabel("t [s]")
        out.append((f"Estimate vs truth: {title}", _fig_to_img(fig)))

    de = distance_and_errors(log)
    fig, ax = plt.subplots(2, 2, figsize=(11, 7), layout="constrained")
    for a, (k, lab, sc) in zip(ax.ravel(), (("position", "m", 1.0), ("attitude", "deg", np.degrees(1.0)),
                                            ("velocity", "m/s", 1.0), ("deck_rates", "deg/s", np.degrees(1.0)))):
        m = de["approach"] if de["approach"].any() else np.ones_like(de["approach"])
        a.plot(de["distance"][m], de[k][m] * sc, color="0.6", lw=0.8, label="per sample")
        x, y = binned_mean(de["distance"][m], de[k][m] * sc)
        a.plot(x, y, "k", lw=1.2, label="mean in 1 cm bins")
        a.set_xlabel("distance to the deck [m]"), a.set_ylabel(f"|{k} error| [{lab}]")
        a.invert_xaxis()
    fig.legend(*ax[0, 0].get_legend_handles_labels(), loc="outside upper center", ncol=2, fontsize=8, frameon=False)
    out.append(("Error norms against distance (final approach)", _fig_to_img(fig)))

    rp = relative_path(log)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5), layout="constrained")
    ax[0].plot(np.hypot(rp[:, 0], rp[:, 1]), -rp[:, 2])
    ax[0].set_xlabel("horizontal distance to the deck [m]"), ax[0].set_ylabel("height above the deck [m]")
    ax[1].plot(rp[:, 1], rp[:, 0])
    ax[1].plot(0, 0, "r+", ms=14)
    ax[1].set_xlabel("deck y [m]"), ax[1].set_ylabel("deck x [m]"), ax[1].axis("equal")
    out.append(("Flown path relative to the deck", _fig_to_img(fig)))
    return out
