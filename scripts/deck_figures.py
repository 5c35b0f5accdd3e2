"""Campaign figures of the deck landings (seed 003 Figs. 5.8-5.11, 5.18-5.21): error norms against the
distance to the deck over many flights (grey) with their mean in 1 cm bins (black), and the flown paths.

    PYTHONPATH=src python scripts/deck_figures.py deck-static 16 docs/figures/deck-static
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


def main(scenario: str, n: int, prefix: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from visnav.analysis.deck_report import binned_mean, distance_and_errors, relative_path
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation

    runs = []
    for seed in range(1, n + 1):
        sim = make_simulation(load_scenario(scenario, seed=seed))
        res = sim.run()
        de = distance_and_errors(sim.log)
        m = de["approach"]
        runs.append(({k: v[m] for k, v in de.items() if k != "approach"}, relative_path(sim.log), res.metrics))
        print(seed, res.metrics["landed"], f"{res.metrics['touchdown_rel_speed_mps']:.3f}", flush=True)
    Path(prefix).parent.mkdir(parents=True, exist_ok=True)

    fig, ax = plt.subplots(2, 2, figsize=(10, 7))
    for a, (k, unit) in zip(ax.ravel(), (("position", "m"), ("attitude", "rad"), ("velocity", "m/s"),
                                         ("deck_rates", "rad/s"))):
        allx, ally = [], []
        for de, _, _ in runs:
            a.plot(de["distance"], de[k], color="0.75", lw=0.6)
            allx.append(de["distance"])
            ally.append(de[k])
        x, y = binned_mean(np.concatenate(allx), np.concatenate(ally))
        a.plot(x, y, "k", lw=1.3, label="mean in 1 cm bins")
        a.set_xlabel("distance to the deck [m]")
        a.set_ylabel(f"|{k} error| [{unit}]")
        a.invert_xaxis()
    ax[0, 0].legend()
    fig.suptitle(f"{scenario}: estimate error norms over the final approach, {len(runs)} flights")
    fig.tight_layout()
    fig.savefig(f"{prefix}-errors.png", dpi=80)

    fig, ax = plt.subplots(1, 2, figsize=(10, 4.2))
    for _, rp, _ in runs:
        ax[0].plot(np.hypot(rp[:, 0], rp[:, 1]), -rp[:, 2], lw=0.8)
        ax[1].plot(rp[:, 1], rp[:, 0], lw=0.8)
    ax[0].set_xlabel("horizontal distance to the deck [m]"), ax[0].set_ylabel("height above the deck [m]")
    ax[1].plot(0, 0, "k+", ms=14)
    ax[1].set_xlabel("deck y [m]"), ax[1].set_ylabel("deck x [m]"), ax[1].axis("equal")
    fig.suptitle(f"{scenario}: flown paths (body origin, deck frame), {len(runs)} flights")
    fig.tight_layout()
    fig.savefig(f"{prefix}-paths.png", dpi=80)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3])
