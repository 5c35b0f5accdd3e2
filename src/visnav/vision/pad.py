"""Landing-pad detection and camera pose (seed 002 ch. 6; the pattern of its ref. [43], our own method).

Pipeline per frame (``PadDetector.detect``):

1. rings with sub-pixel ellipses and the exact image of each ring centre (``vision/ellipses.py``);
2. association: for every configuration k (geometry/pad.py) the rings whose measured radius ratio
   (a projective invariant) fits its ``inner_ratio`` within ``ratio_tol`` form triples (sizes within
   ``size_ratio_max``); each triple and each of its 6 orderings is a hypothesis;
3. correspondences: the three centre images m_i, and on each line m_i m_j the two intersections with
   ring i's outer and inner image ellipses. The plane line through the centres c_i, c_j maps to the
   image line through m_i, m_j, so these are *exact* images of c_i -/+ rho u_ij (rho = r_out, r_in):
   27 points (3 centres + 3 rings x 2 neighbours x 2 radii x 2 sides), no perspective bias;
4. homography of the pad plane by normalised DLT (``vision/homography.py``) from the 27 points;
   hypothesis kept when its RMS transfer error is below ``max_rms_px`` + ``rel_rms`` x ring size and
   the decomposition puts the camera above the pad (the mirror ordering of the isosceles triangle
   fits equally well, but with the camera below the plane); a configuration matched by two
   different triples is ambiguous and dropped;
5. the largest configuration matched is used: pose from the homography (K^-1 H = lambda [r1 r2 t],
   R orthonormalised by SVD), refined by Gauss-Newton on the reprojection error of the 27 points
   (the same minimum cv2.solvePnP's iterative method reaches; tests compare them);
6. covariance: first-order propagation of the point noise, Cov(pose) = s^2 (J^T J)^-1 with J the
   reprojection Jacobian, s the a-posteriori point sigma (floor ``sigma_floor_px``) times
   ``cov_inflation`` (the 27 points come from 6 ellipses: correlated); the camera-centre covariance
   follows through c = -R^T t. Its growth with range is that of J: sigma ~ range^2 / (f size).

Frames: pad frame = NED at the pad centre; camera = OpenCV. ``R`` maps pad to camera
(x_cam = R X + t); the camera centre is c = -R^T t and C_cn = R^T.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from visnav.geometry.pad import PadLayout
from visnav.geometry.rotations import skew
from visnav.vision.ellipses import Ring, detect_rings, line_conic_intersections
from visnav.vision.homography import normalized_dlt

__all__ = ["PadDetection", "PadDetector", "PadPose", "pose_from_homography", "refine_pose", "rotvec_to_dcm"]


def rotvec_to_dcm(w: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(w))
    if th < 1e-12:
        return np.eye(3) + skew(w)
    k = skew(w / th)
    return np.eye(3) + np.sin(th) * k + (1 - np.cos(th)) * (k @ k)


@dataclass
class PadPose:
    position: np.ndarray  # camera centre in the pad frame [m]
    R: np.ndarray  # pad frame -> camera
    t: np.ndarray
    cov: np.ndarray  # 3x3 covariance of the camera centre [m^2]
    cov6: np.ndarray  # 6x6 of (rotation vector (left), t)
    config: int
    rms_px: float
    sigma_px: float

    @property
    def C_cn(self) -> np.ndarray:
        return self.R.T


@dataclass
class PadDetection:
    rings: list[Ring]
    pose: PadPose | None
    reason: str = ""
    pad_centre_px: np.ndarray | None = None  # image of the pad centre (for the pan-tilt tracker)
    matched: dict = field(default_factory=dict)  # config -> RMS [px] of each configuration matched


def pose_from_homography(H: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(R, t) with x ~ K (R [X, Y, 0]^T + t) from the plane homography H, or None when the plane
    would lie behind the camera or the camera below the plane (a mirrored fit)."""
    A = np.linalg.solve(K, H)
    lam = 2.0 / (np.linalg.norm(A[:, 0]) + np.linalg.norm(A[:, 1]))
    if A[2, 2] * lam < 0:
        lam = -lam
    r1, r2, t = lam * A[:, 0], lam * A[:, 1], lam * A[:, 2]
    R0 = np.column_stack([r1, r2, np.cross(r1, r2)])
    U, _, Vt = np.linalg.svd(R0)
    R = U @ Vt
    if np.linalg.det(R) < 0:
        return None
    c = -R.T @ t
    if c[2] >= 0:  # camera at or below the pad plane (z down)
        return None
    return R, t


def _project(R, t, X, K):
    Xc = X @ R.T + t
    z = Xc[:, 2]
    return np.column_stack([K[0, 0] * Xc[:, 0] / z + K[0, 2], K[1, 1] * Xc[:, 1] / z + K[1, 2]]), Xc


def refine_pose(R, t, X, uv, K, iters: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Gauss-Newton on the reprojection error of points X (N, 3) seen at uv (N, 2).
    Returns R, t, the Jacobian (2N, 6) w.r.t. (left rotation vector, t) and the RSS [px^2]."""
    fx, fy = K[0, 0], K[1, 1]
    for it in range(iters + 1):
        p, Xc = _project(R, t, X, K)
        r = (uv - p).ravel()
        x, y, z = Xc[:, 0], Xc[:, 1], Xc[:, 2]
        n = len(X)
        Jp = np.zeros((n, 2, 3))
        Jp[:, 0, 0] = fx / z
        Jp[:, 0, 2] = -fx * x / z**2
        Jp[:, 1, 1] = fy / z
        Jp[:, 1, 2] = -fy * y / z**2
        RX = Xc - t
        # d(Xc)/d(dtheta) = -[RX]x ; d(Xc)/dt = I
        S = np.zeros((n, 3, 3))
        S[:, 0, 1], S[:, 0, 2], S[:, 1, 2] = -RX[:, 2], RX[:, 1], -RX[:, 0]
        S[:, 1, 0], S[:, 2, 0], S[:, 2, 1] = RX[:, 2], -RX[:, 1], RX[:, 0]
        J = np.concatenate([Jp @ (-S), Jp], axis=2).reshape(2 * n, 6)
        if it == iters:
            return R, t, J, float(r @ r)
        d = np.linalg.lstsq(J, r, rcond=None)[0]
        R = rotvec_to_dcm(d[:3]) @ R
        t = t + d[3:]
        if np.linalg.norm(d) < 1e-12:
            p, _ = _project(R, t, X, K)
            r = (uv - p).ravel()
            return R, t, J, float(r @ r)
    raise AssertionError("unreachable")


class PadDetector:
    def __init__(self, layout: PadLayout, K: np.ndarray, *, ratio_tol: float = 0.09, size_ratio_max: float = 2.0,
                 max_rms_px: float = 0.4, rel_rms: float = 0.004, sigma_floor_px: float = 0.05,
                 cov_inflation: float = 1.5, shape_tol: float = 1.4, size_tol: float = 1.15,
                 nested_ratio: float = 1.6, block: int = 51, offset: float = 30.0, min_radius_px: float = 4.0):
        self.layout = layout
        self.configs = layout.configurations()
        self.K = np.asarray(K, float)
        self.ratio_tol, self.size_ratio_max = ratio_tol, size_ratio_max
        self.max_rms_px, self.rel_rms = max_rms_px, rel_rms
        self.sigma_floor_px, self.cov_inflation = sigma_floor_px, cov_inflation
        self.block, self.offset, self.min_radius_px = block, offset, min_radius_px
        self.shape_tol, self.size_tol, self.nested_ratio = shape_tol, size_tol, nested_ratio
        self._plane = {}
        for cfg in self.configs:
            pts, keys = cfg.line_points()
            self._plane[cfg.index] = (np.column_stack([pts, np.zeros(len(pts))]), keys)

    # ------------------------------------------------------------------ correspondences
    @staticmethod
    def intersections(rings: list[Ring]) -> dict:
        """(a, b, w) -> the two points where the line from ring a's centre to ring b's meets ring
        a's outer (w = 1) or inner (w = 2) ellipse (first the one away from b)."""
        out = {}
        for a in range(3):
            for b in range(3):
                if a != b:
                    for w, Q in ((1, rings[a].Q_out), (2, rings[a].Q_in)):
                        out[(a, b, w)] = line_conic_intersections(rings[a].centre, rings[b].centre, Q)
        return out

    @staticmethod
    def image_points(rings: list[Ring], keys: np.ndarray, perm: tuple[int, int, int], cache=None) -> np.ndarray:
        """Image points (27, 2) matching the plane points of ``keys`` when image ring a plays the
        role of configuration vertex perm[a]."""
        cache = PadDetector.intersections(rings) if cache is None else cache
        inv = {perm[a]: a for a in range(3)}
        out = np.empty((len(keys), 2))
        for n, (i, j, w, sgn) in enumerate(keys):
            a = inv[i]
            out[n] = rings[a].centre if j < 0 else cache[(a, inv[j], w)][0 if sgn < 0 else 1]
        return out

    def _hypotheses(self, rings: list[Ring]):
        """(configuration, ring triple, ordering) worth a homography: the triple's centres form a
        roughly right isosceles triangle (legs and hypotenuse within ``shape_tol``) whose legs
        fit the rings' size for that configuration's r/L; the right angle is the vertex opposite the
        longest side, and B, C follow from the orientation (seen from above, (B - A) x (C - A) > 0
        in image axes as in north-east axes: no mirror between them)."""
        st = self.shape_tol
        cen = np.array([r.centre for r in rings])
        size = np.array([r.size for r in rings])
        ratio = np.array([r.ratio for r in rings])
        for cfg in self.configs:
            cand = np.flatnonzero(np.abs(ratio - self.layout.inner_ratio[cfg.index]) < self.ratio_tol)
            if len(cand) < 3:
                continue
            T = np.array(list(itertools.combinations(cand, 3)))
            sz = size[T]
            m = cen[T]  # (M, 3, 2)
            d = np.stack([np.linalg.norm(m[:, 1] - m[:, 2], axis=1), np.linalg.norm(m[:, 0] - m[:, 2], axis=1),
                          np.linalg.norm(m[:, 0] - m[:, 1], axis=1)], axis=1)
            a = np.argmax(d, axis=1)
            legs = np.sort(d, axis=1)[:, :2]
            lm = legs.mean(axis=1)
            hyp = d[np.arange(len(T)), a] / lm
            fit = sz.mean(axis=1) / (self.layout.ring_ratio[cfg.index] * lm)
            ok = ((sz.max(axis=1) <= self.size_ratio_max * sz.min(axis=1)) & (legs[:, 1] < st * legs[:, 0])
                  & (hyp > np.sqrt(2) / st) & (hyp < np.sqrt(2) * st) & (fit > 1.0 / self.size_tol)
                  & (fit < self.size_tol))
            for n in np.flatnonzero(ok):
                ai = int(a[n])
                b, c = [j for j in range(3) if j != ai]
                u, v = m[n, b] - m[n, ai], m[n, c] - m[n, ai]
                if u[0] * v[1] - u[1] * v[0] < 0:
                    b, c = c, b
                perm = [0, 0, 0]
                perm[ai], perm[b], perm[c] = 0, 1, 2
                yield cfg, tuple(int(i) for i in T[n]), tuple(perm)

    def _nested_copy(self, fits: list, rings: list[Ring]) -> bool:
        """Several triples fit one configuration; true when the largest is at least
        ``nested_ratio`` times the size of every other and all share its imaged pad centre:
        the others are smaller configurations, seen too small to read their radius ratio."""
        size = [np.mean([rings[i].size for i in f[1]]) for f in fits]
        order = np.argsort(size)[::-1]
        big = fits[order[0]]
        c0 = self.K @ big[4][1]
        for i in order[1:]:
            if fits[i][1] == big[1]:
                continue
            c = self.K @ fits[i][4][1]
            if size[order[0]] < self.nested_ratio * size[i] or \
                    np.hypot(*(c[:2] / c[2] - c0[:2] / c0[2])) > 2.0 + 0.2 * size[i]:
                return False
        return True

    def detect(self, gray: np.ndarray) -> PadDetection:
        rings = detect_rings(gray, block=self.block, offset=self.offset, min_radius_px=self.min_radius_px)
        if len(rings) < 3:
            return PadDetection(rings, None, f"{len(rings)} rings")
        hyps = list(self._hypotheses(rings))

        def evaluate(cfg, tri, perm):
            X, keys = self._plane[cfg.index]
            sub = [rings[i] for i in tri]
            tol = self.max_rms_px + self.rel_rms * float(np.mean([r.size for r in sub]))
            uv = self.image_points(sub, keys, perm)
            if not np.all(np.isfinite(uv)):
                return None
            H = normalized_dlt(X[:, :2], uv)
            q = np.column_stack([X[:, :2], np.ones(len(X))]) @ H.T
            e = q[:, :2] / q[:, 2:3] - uv
            rms = float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
            pt = pose_from_homography(H, self.K) if rms <= tol else None
            return None if pt is None else (rms, tri, perm, uv, pt)

        matched, ambiguous = {}, False
        for cfg in self.configs:  # largest first: stop at the first one matched unambiguously
            ok = [f for f in (evaluate(c, tri, perm) for c, tri, perm in hyps if c is cfg) if f is not None]
            # a triple fitting a smaller configuration better belongs to that one
            own = []
            for f in ok:
                others = [evaluate(c, tri, perm) for c, tri, perm in hyps if tri == f[1] and c is not cfg]
                if all(o is None or o[0] >= f[0] for o in others):
                    own.append(f)
            if len({f[1] for f in own}) > 1 and not self._nested_copy(own, rings):
                ambiguous = True  # two different ring triples fit: ambiguous
                continue
            if own:
                matched[cfg.index] = max(own, key=lambda f: np.mean([rings[i].size for i in f[1]]))
                break
        if not matched:
            return PadDetection(rings, None, "ambiguous configuration" if ambiguous else "no configuration")
        k = min(matched)
        rms, tri, perm, uv, (R, t) = matched[k]
        pose = self.refine(k, uv, R, t)
        if pose is None:
            return PadDetection(rings, None, "singular pose")
        pc = self.K @ pose.t  # image of the pad centre (X = 0)
        return PadDetection(rings, pose, "", pc[:2] / pc[2], {kk: v[0] for kk, v in matched.items()})

    def refine(self, k: int, uv: np.ndarray, R: np.ndarray, t: np.ndarray) -> PadPose | None:
        """Gauss-Newton pose of configuration ``k`` from its 27 image points and the covariance."""
        X = self._plane[k][0]
        R, t, J, rss = refine_pose(R, t, X, uv, self.K)
        dof = max(2 * len(X) - 6, 1)
        sigma = max(np.sqrt(rss / dof), self.sigma_floor_px) * self.cov_inflation
        try:
            cov6 = sigma**2 * np.linalg.inv(J.T @ J)
        except np.linalg.LinAlgError:
            return None
        Jc = np.hstack([-R.T @ skew(t), -R.T])
        return PadPose(-R.T @ t, R, t, Jc @ cov6 @ Jc.T, cov6, k, float(np.sqrt(rss / len(X))), float(sigma))

    def pose_from_rings(self, rings: list[Ring], k: int) -> PadPose | None:
        """Pose from the three rings of configuration ``k`` given in the order A, B, C."""
        X, keys = self._plane[k]
        uv = self.image_points(rings, keys, (0, 1, 2))
        pt = pose_from_homography(normalized_dlt(X[:, :2], uv), self.K)
        return None if pt is None else self.refine(k, uv, *pt)
