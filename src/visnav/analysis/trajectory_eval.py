"""Trajectory evaluation: absolute trajectory error (ATE / APE) and relative pose error (RPE).

The same definitions as the TUM RGB-D benchmark (Sturm et al. 2012) and ``evo``, which the tests
compare against to 1e-6 on the same files:

- association: every pose of the trajectory with fewer poses is paired with the nearest-in-time pose
  of the other within ``max_diff`` seconds (after adding ``offset_s`` to the estimate's stamps);
- alignment ``none | se3 | sim3``: Umeyama's closed form (IEEE PAMI 1991, eq. 34-43) of the rotation,
  translation and (sim3) scale that bring the estimated positions onto the reference;
- APE: the translation error ``|p_ref_i - p_est_i|`` per associated pose;
- RPE: the translation part of ``(Q_i^-1 Q_j)^-1 (P_i^-1 P_j)`` over consecutive pairs ``(i, j)`` that
  are ``delta`` poses apart (``unit="frames"``) or ``delta`` metres of reference path apart
  (``unit="m"``);
- drift: per segment of ``length_m`` metres of reference path, the end-point error of the estimate's
  displacement over the segment in % of the length (translation only, world frame: the position
  drift of a navigation solution, which is what the theses quote).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation
import csv


class TrajectoryError(ValueError):
    """A trajectory that cannot be read or evaluated; the message names the file and the problem."""


@dataclass
class Trajectory:
    """Poses at stamps: ``t`` (N,), positions ``p`` (N, 3) and unit quaternions ``q`` (N, 4) x, y, z, w
    (body -> world). ``frame`` says what the world is (from the TUM header or the run)."""

    t: np.ndarray
    p: np.ndarray
    q: np.ndarray
    name: str = ""
    frame: str = ""

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, float).reshape(-1)
        self.p = np.asarray(self.p, float).reshape(-1, 3)
        self.q = np.asarray(self.q, float).reshape(-1, 4)
        if not (len(self.t) == len(self.p) == len(self.q)):
            raise TrajectoryError(f"{self.name}: {len(self.t)} stamps, {len(self.p)} positions, {len(self.q)} "
                                  "orientations")

    def __len__(self) -> int:
        return len(self.t)

    def subset(self, idx) -> "Trajectory":
        return Trajectory(self.t[idx], self.p[idx], self.q[idx], self.name, self.frame)

    def poses(self) -> np.ndarray:
        """(N, 4, 4) homogeneous poses."""
        T = np.zeros((len(self), 4, 4))
        T[:, :3, :3] = Rotation.from_quat(self.q).as_matrix()
        T[:, :3, 3] = self.p
        T[:, 3, 3] = 1.0
        return T

    def path_length(self) -> np.ndarray:
        """Cumulative path length at each pose [m]."""
        return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self.p, axis=0), axis=1))])


# ------------------------------------------------------------------------------------------ reading
def _frame_from_header(path: Path) -> str:
    with open(path, "r", errors="replace") as fh:
        for line in fh:
            if not line.startswith("#"):
                break
            text = line.lstrip("#").strip()
            low = text.lower()
            if "frame:" in low:
                return text[low.index("frame:") + 6:].strip()
            if "(" in text:
                return text
    return ""


def _read_tum(path: Path) -> Trajectory:
    try:
        with warnings.catch_warnings():  # an empty file: numpy's UserWarning, then "no poses" below
            warnings.simplefilter("ignore", UserWarning)
            d = np.loadtxt(path, comments="#", ndmin=2)
    except ValueError as exc:
        raise TrajectoryError(f"{path}: not a TUM file ({exc})") from None
    if d.size == 0:
        raise TrajectoryError(f"{path}: no poses")
    if d.shape[1] != 8:
        raise TrajectoryError(f"{path}: a TUM file has 8 columns (t tx ty tz qx qy qz qw), found {d.shape[1]}")
    return Trajectory(d[:, 0], d[:, 1:4], d[:, 4:8], name=path.name, frame=_frame_from_header(path))


_CSV_T = ("t", "t_s", "time", "time_s", "timestamp", "timestamp_s")
_CSV_P = (("x", "y", "z"), ("x_m", "y_m", "z_m"), ("n_m", "e_m", "d_m"), ("north_m", "east_m", "down_m"),
          ("tx", "ty", "tz"))
_CSV_Q = ("qx", "qy", "qz", "qw")


def _read_csv(path: Path) -> Trajectory:
    with open(path, newline="") as fh:
        header = next(csv.reader(fh), None)
    if not header:
        raise TrajectoryError(f"{path}: empty CSV")
    cols = [h.strip().lower() for h in header]
    try:
        with warnings.catch_warnings():  # no rows: numpy's UserWarning, then "no rows" below
            warnings.simplefilter("ignore", UserWarning)
            data = np.genfromtxt(path, delimiter=",", skip_header=1, ndmin=2)
    except ValueError as exc:
        raise TrajectoryError(f"{path}: {exc}") from None
    if data.size == 0:
        raise TrajectoryError(f"{path}: no rows")
    tcol = next((cols.index(c) for c in _CSV_T if c in cols), None)
    pcols = next(([cols.index(c) for c in names] for names in _CSV_P if all(c in cols for c in names)), None)
    if tcol is None or pcols is None:
        raise TrajectoryError(f"{path}: needs a time column ({' / '.join(_CSV_T)}) and position columns "
                              f"(x_m, y_m, z_m or n_m, e_m, d_m); found {', '.join(cols)}")
    if all(c in cols for c in _CSV_Q):
        q = data[:, [cols.index(c) for c in _CSV_Q]]
    elif all(c in cols for c in ("roll_rad", "pitch_rad", "yaw_rad")):
        e = data[:, [cols.index(c) for c in ("yaw_rad", "pitch_rad", "roll_rad")]]
        q = Rotation.from_euler("ZYX", e).as_quat()
    else:
        q = np.tile([0.0, 0.0, 0.0, 1.0], (len(data), 1))
    ok = np.isfinite(data[:, tcol]) & np.all(np.isfinite(data[:, pcols]), axis=1)
    if not ok.any():
        raise TrajectoryError(f"{path}: no row with a finite time and position")
    return Trajectory(data[ok, tcol], data[ok][:, pcols], q[ok], name=path.name)


def read_trajectory(path: str | Path, *, which: str = "estimate") -> Trajectory:
    """A TUM file, a CSV with a header (``t_s, x_m, y_m, z_m[, qx, qy, qz, qw]``), or a run directory
    (its ``estimate.tum`` or ``truth.tum``: ``which``)."""
    p = Path(path)
    if p.is_dir():
        f = p / f"{which}.tum"
        if not f.is_file():
            raise TrajectoryError(f"{p}: a run directory holds {which}.tum, not found")
        tr = _read_tum(f)
        tr.name = f"{p.name}/{f.name}"
        return tr
    if not p.is_file():
        raise TrajectoryError(f"{p}: no such file")
    tr = _read_csv(p) if p.suffix.lower() == ".csv" else _read_tum(p)
    if np.any(np.diff(tr.t) < 0):
        raise TrajectoryError(f"{p}: timestamps out of order (first at row {int(np.argmax(np.diff(tr.t) < 0)) + 2})")
    return tr


# ------------------------------------------------------------------------------------------ association
def associate(ref: Trajectory, est: Trajectory, max_diff: float = 0.01, offset_s: float = 0.0
              ) -> tuple[Trajectory, Trajectory]:
    """Pair poses by nearest time stamp (evo's rule): each pose of the shorter trajectory with the
    nearest pose of the longer one within ``max_diff``; ``offset_s`` is added to the estimate's stamps."""
    second_longer = len(est) > len(ref)
    short, long_ = (ref, est) if second_longer else (est, ref)
    off = offset_s if second_longer else -offset_s
    ts, tl = short.t, long_.t + off
    if len(tl) == 0 or len(ts) == 0:
        raise TrajectoryError("an empty trajectory cannot be associated")
    i2 = np.minimum(np.searchsorted(tl, ts, side="right"), len(tl) - 1)
    diff_ub = tl[i2] - ts
    diff_lb = np.where(i2 > 0, ts - tl[np.maximum(i2 - 1, 0)], np.inf)
    inside = (ts >= tl[0] - max_diff) & (ts <= tl[-1] + max_diff)
    use_ub = (diff_ub <= max_diff) & (diff_ub < diff_lb)
    use_lb = ~use_ub & (diff_lb <= max_diff) & (diff_lb <= diff_ub)
    keep = inside & (use_ub | use_lb)
    i1 = np.nonzero(keep)[0]
    best = np.where(use_ub, i2, i2 - 1)[keep]
    if len(i1) == 0:
        raise TrajectoryError(f"no matching time stamps between {ref.name or 'reference'} and "
                              f"{est.name or 'estimate'} within {max_diff} s (offset {offset_s} s)")
    a, b = short.subset(i1), long_.subset(best)
    return (a, b) if second_longer else (b, a)


# ------------------------------------------------------------------------------------------ alignment
def umeyama(x: np.ndarray, y: np.ndarray, with_scale: bool = False) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares R, t, c with ``y ~ c R x + t`` for point sets ``x``, ``y`` of shape (N, m)
    (Umeyama 1991, eq. 34-43)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    n, m = x.shape
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    var_x = np.sum(xc * xc) / n
    cov = yc.T @ xc / n
    u, d, vt = np.linalg.svd(cov)
    if np.count_nonzero(d > np.finfo(float).eps) < m - 1:
        raise TrajectoryError("degenerate trajectory (all poses on a line or a point): cannot align")
    s = np.eye(m)
    if np.linalg.det(u) * np.linalg.det(vt) < 0.0:
        s[-1, -1] = -1.0
    r = u @ s @ vt
    c = float(np.trace(np.diag(d) @ s) / var_x) if with_scale else 1.0
    t = my - c * r @ mx
    return r, t, c


def align(ref: Trajectory, est: Trajectory, mode: str = "se3") -> tuple[Trajectory, dict]:
    """The estimate brought onto the reference (``none | se3 | sim3``); returns it and the transform."""
    if mode == "none":
        return est, {"rotation": np.eye(3), "translation": np.zeros(3), "scale": 1.0}
    if mode not in ("se3", "sim3"):
        raise TrajectoryError(f"alignment must be none, se3 or sim3, got {mode!r}")
    r, t, c = umeyama(est.p, ref.p, with_scale=(mode == "sim3"))
    p = c * est.p @ r.T + t
    q = (Rotation.from_matrix(r) * Rotation.from_quat(est.q)).as_quat()
    return Trajectory(est.t, p, q, est.name, ref.frame), {"rotation": r, "translation": t, "scale": c}


# ------------------------------------------------------------------------------------------ metrics
def stats(err: np.ndarray) -> dict:
    err = np.asarray(err, float)
    if err.size == 0:
        return {k: float("nan") for k in ("rmse", "mean", "median", "std", "min", "max", "sse")} | {"count": 0}
    return {"rmse": float(np.sqrt(np.mean(err ** 2))), "mean": float(np.mean(err)),
            "median": float(np.median(err)), "std": float(np.std(err)), "min": float(np.min(err)),
            "max": float(np.max(err)), "sse": float(np.sum(err ** 2)), "count": int(err.size)}


def ape(ref: Trajectory, est: Trajectory) -> np.ndarray:
    """Translation error of associated (and aligned) poses [m]."""
    return np.linalg.norm(ref.p - est.p, axis=1)


def pairs(ref: Trajectory, delta: float, unit: str = "frames") -> np.ndarray:
    """Consecutive index pairs ``delta`` poses (``frames``) or ``delta`` metres of path (``m``) apart."""
    n = len(ref)
    if unit == "frames":
        d = int(delta)
        if d < 1:
            raise TrajectoryError(f"RPE delta in frames must be >= 1, got {delta}")
        ids = np.arange(0, n, d)
    elif unit == "m":
        if not delta > 0:
            raise TrajectoryError(f"RPE delta in metres must be > 0, got {delta}")
        step = np.linalg.norm(np.diff(ref.p, axis=0), axis=1)
        ids, acc = [0], 0.0  # path accumulated since the last chosen pose (evo's rule, a reset each time)
        for i, s in enumerate(step, start=1):
            acc += s
            if acc >= delta:
                ids.append(i)
                acc = 0.0
        ids = np.asarray(ids)
    else:
        raise TrajectoryError(f"RPE unit must be frames or m, got {unit!r}")
    return np.column_stack([ids[:-1], ids[1:]]).astype(int)


def rpe(ref: Trajectory, est: Trajectory, delta: float = 1, unit: str = "frames") -> np.ndarray:
    """Translation part of the relative pose error over consecutive pairs [m]."""
    ij = pairs(ref, delta, unit)
    if len(ij) == 0:
        return np.zeros(0)
    Q, P = ref.poses(), est.poses()
    i, j = ij[:, 0], ij[:, 1]
    inv = np.linalg.inv
    dq = inv(Q[i]) @ Q[j]
    dp = inv(P[i]) @ P[j]
    E = inv(dq) @ dp
    return np.linalg.norm(E[:, :3, 3], axis=1)


def segment_drift(ref: Trajectory, est: Trajectory, length_m: float) -> np.ndarray:
    """Drift in % of distance over every segment of ``length_m`` metres of reference path that starts
    at an associated pose (vectorised over start points)."""
    s = ref.path_length()
    j = np.searchsorted(s, s + length_m, side="left")
    ok = j < len(s)
    i, j = np.nonzero(ok)[0], j[ok]
    if len(i) == 0:
        return np.zeros(0)
    e = (est.p[j] - est.p[i]) - (ref.p[j] - ref.p[i])
    return 100.0 * np.linalg.norm(e, axis=1) / (s[j] - s[i])


@dataclass
class Evaluation:
    ref: Trajectory
    est: Trajectory  # associated and aligned
    alignment: dict
    ape: np.ndarray
    rpe: np.ndarray
    drift: dict = field(default_factory=dict)  # segment length -> drift % per segment
    matched: int = 0
    ref_poses: int = 0
    est_poses: int = 0

    def summary(self) -> dict:
        out = {"matched_poses": self.matched, "reference_poses": self.ref_poses, "estimate_poses": self.est_poses,
               "alignment_scale": float(self.alignment["scale"])}
        out |= {f"ate_{k}_m" if k != "count" else "ate_count": v for k, v in stats(self.ape).items()}
        out |= {f"rpe_{k}_m" if k != "count" else "rpe_count": v for k, v in stats(self.rpe).items()}
        for length, d in self.drift.items():
            st = stats(d)
            out[f"drift_{length:g}m_mean_pct"] = st["mean"]
            out[f"drift_{length:g}m_max_pct"] = st["max"]
        return out


def evaluate(ref: Trajectory, est: Trajectory, *, alignment: str = "none", max_diff: float = 0.01,
             offset_s: float = 0.0, rpe_delta: float = 1, rpe_unit: str = "frames",
             drift_lengths_m=()) -> Evaluation:
    """Associate, align, and compute APE, RPE and segment drift of ``est`` against ``ref``."""
    r, e = associate(ref, est, max_diff, offset_s)
    if alignment != "none" and len(r) < 3:
        raise TrajectoryError(f"{len(r)} associated poses: at least 3 are needed to align")
    e_al, tf = align(r, e, alignment)
    drift = {float(L): segment_drift(r, e_al, float(L)) for L in drift_lengths_m}
    return Evaluation(ref=r, est=e_al, alignment=tf, ape=ape(r, e_al), rpe=rpe(r, e_al, rpe_delta, rpe_unit),
                      drift=drift, matched=len(r), ref_poses=len(ref), est_poses=len(est))
