"""Monte Carlo noise analysis of the visual odometry (seed 002 §5.6.1, eq. 5.11, Figs. 5.6-5.11).

n features are drawn in a 360 x 288 image (uniformly over the whole image, or on its left third for
the one-sided layout of Fig. 5.9); image 2 shows the same features (H = I: no motion). Each trial adds
Gaussian noise sigma_pi [px] to the features in both images and sigma_alpha to the roll, pitch and
heading of both camera attitudes, estimates H by the normalized DLT and evaluates eq. 5.9-5.10 with the
unit depth d = 1. The normalized odometry noise sigma_tau is the standard deviation of the north
(and east) displacement over the trials (eq. 5.11); the one-axis noise at height d is d sigma_tau
(Fig. 5.8). Everything is vectorised over the trials (batched SVD).

Closed form used by the tests: with noise-free pixels, M = C2 C1^T ~ I + [dtheta x], so the north
displacement is the difference of two independent tilt errors: sigma_tau = sqrt(2) sigma_alpha [rad].
"""

from __future__ import annotations

import math

import numpy as np

from visnav.vision.homography import _dlt_rows
from pathlib import Path

IMAGE = (360, 288)
FOCAL_PX = 0.5 * IMAGE[0] / math.tan(math.radians(22.5))  # ~45 deg horizontal view (§5.9)


def _euler_dcm(e: np.ndarray) -> np.ndarray:
    """(N, 3) roll, pitch, yaw -> (N, 3, 3) body -> NED (ZYX)."""
    r, p, y = e[:, 0], e[:, 1], e[:, 2]
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    C = np.empty((len(e), 3, 3))
    C[:, 0, 0], C[:, 0, 1], C[:, 0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    C[:, 1, 0], C[:, 1, 1], C[:, 1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    C[:, 2, 0], C[:, 2, 1], C[:, 2, 2] = -sp, cp * sr, cp * cr
    return C


def _batched_dlt(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """Normalized DLT (Algorithm 2) on (N, n, 2) point sets -> (N, 3, 3)."""
    def norm(x):
        c = x.mean(axis=1, keepdims=True)
        s = math.sqrt(2) / np.sqrt(((x - c) ** 2).sum(-1)).mean(-1)
        T = np.zeros((len(x), 3, 3))
        T[:, 0, 0] = T[:, 1, 1] = s
        T[:, :2, 2] = -s[:, None] * c[:, 0]
        T[:, 2, 2] = 1
        return (x - c) * s[:, None, None], T

    a, T1 = norm(x1)
    b, T2 = norm(x2)
    _, _, Vt = np.linalg.svd(_dlt_rows(a, b), full_matrices=False)
    Hn = Vt[:, -1].reshape(-1, 3, 3)
    return np.linalg.solve(T2, Hn @ T1)


def odometry_noise(n_features: int, sigma_px: float, sigma_att_deg: float = 0.0, layout: str = "uniform",
                   trials: int = 1000, rng: np.random.Generator | None = None, image=IMAGE,
                   focal_px: float = FOCAL_PX) -> np.ndarray:
    """Normalized odometry noise (sigma_tau north, sigma_tau east) at d = 1 (eq. 5.11).

    The camera looks straight down, image x to the east and image y to the south (heading 0), so the
    one-sided layout (features on the left third, small x) weakens the east axis most."""
    if layout not in ("uniform", "one-sided"):
        raise ValueError(f"layout must be 'uniform' or 'one-sided', got {layout!r}")
    if n_features < 4:
        raise ValueError(f"n_features must be >= 4, got {n_features}")
    rng = rng if rng is not None else np.random.default_rng(0)
    w, h = image
    xmax = w / 3.0 if layout == "one-sided" else w
    pts = np.column_stack([rng.uniform(0, xmax, n_features), rng.uniform(0, h, n_features)])
    K = np.array([[focal_px, 0, w / 2.0], [0, focal_px, h / 2.0], [0, 0, 1.0]])
    Kinv = np.linalg.inv(K)
    x1 = pts + sigma_px * rng.standard_normal((trials, n_features, 2))
    x2 = pts + sigma_px * rng.standard_normal((trials, n_features, 2))
    H = _batched_dlt(x1, x2) if sigma_px > 0 else np.broadcast_to(np.eye(3), (trials, 3, 3))
    # camera -> NED for a nadir camera at heading 0: x_cam = east, y_cam = south, z_cam = down
    R_cn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    sa = math.radians(sigma_att_deg)
    C1 = _euler_dcm(sa * rng.standard_normal((trials, 3))) @ R_cn
    C2 = _euler_dcm(sa * rng.standard_normal((trials, 3))) @ R_cn
    M = C2 @ Kinv @ H @ K @ np.swapaxes(C1, 1, 2)
    M = M / (0.5 * (M[:, 0, 0] + M[:, 1, 1]))[:, None, None]
    t = -(M - np.eye(3))[:, :2, 2]  # eq. 5.9-5.10 with d = 1
    return t.std(axis=0)


def noise_figures(trials: int = 1000, seed: int = 0) -> list[tuple[str, object]]:
    """Figures 5.6, 5.7, 5.8, 5.10, 5.11 as matplotlib figures: [(title, fig)]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(seed)
    ns = [8, 12, 16, 25, 35, 50, 75, 100, 150]
    sig_px = [0.5, 1.0, 2.0, 3.0]
    out = []
    for layout, fig_no in (("uniform", "5.6"), ("one-sided", "5.10")):
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for s in sig_px:
            st = np.array([odometry_noise(n, s, 0.0, layout, trials, rng) for n in ns])
            ax.plot(ns, st[:, 0], "o-", label=f"sigma_pi = {s} px, north")
            if layout == "one-sided":
                ax.plot(ns, st[:, 1], "x--", label=f"sigma_pi = {s} px, east")
        ax.set_xlabel("features per image"), ax.set_ylabel("sigma_tau (d = 1)"), ax.set_yscale("log")
        ax.legend(fontsize=7), ax.set_title(f"Fig. {fig_no}: pixel noise, {layout} features")
        out.append((f"Fig. {fig_no}", fig))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    sa = np.array([0.1, 0.25, 0.5, 0.75, 1.0])
    st = np.array([odometry_noise(50, 0.0, a, "uniform", trials, rng) for a in sa])
    ax.plot(sa, st[:, 0], "o-", label="Monte Carlo (north)")
    ax.plot(sa, math.sqrt(2) * np.radians(sa), "k--", label="sqrt(2) sigma_alpha")
    ax.set_xlabel("sigma_alpha [deg]"), ax.set_ylabel("sigma_tau (d = 1)"), ax.legend()
    ax.set_title("Fig. 5.7: attitude noise, noise-free pixels")
    out.append(("Fig. 5.7", fig))
    for layout, fig_no in (("uniform", "5.8"), ("one-sided", "5.11")):
        st = odometry_noise(50, 2.0, 0.5, layout, trials, rng)
        d = np.linspace(10, 500, 50)
        fig, ax = plt.subplots(figsize=(7, 4.5))
        ax.plot(d, d * st[0], label="north")
        ax.plot(d, d * st[1], "--", label="east")
        ax.set_xlabel("height above ground d [m]"), ax.set_ylabel("odometry noise, 1 sigma [m]")
        ax.legend(), ax.set_title(f"Fig. {fig_no}: sigma_pi = 2 px, sigma_alpha = 0.5 deg, 50 {layout} features")
        out.append((f"Fig. {fig_no}", fig))
    return out


def write_figures(out_dir, trials: int = 1000, seed: int = 0) -> list:
    """Save the §5.6.1 figures as PNG files in ``out_dir``; returns the paths."""

    import matplotlib.pyplot as plt

    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    paths = []
    for title, fig in noise_figures(trials, seed):
        p = d / (title.replace(" ", "_").replace(".", "_") + ".png")
        fig.savefig(p, dpi=90, bbox_inches="tight")
        plt.close(fig)
        paths.append(p)
    return paths
