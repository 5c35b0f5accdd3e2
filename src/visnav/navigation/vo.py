"""A frame-only visual-odometry navigator for recordings without an IMU (photo surveys): ``--navigator vo``.

Each photo is registered to earlier photos by local features and a robust homography
(``vision/features.py``). Over flat ground the homography of two views is H = K (R + t n^T / d) K^-1
(seed 002 appendix B; OpenCV ``decomposeHomographyMat``, Malis & Vargas): R, t the motion of the
camera (X_a = R X_b + t, so t is b's centre in a's camera frame), n the ground normal in b's frame
and d b's distance to the ground, t returned divided by d. Of the four solutions the one kept has the
ground in front of b (n_z > 0) and the ground normal in a's frame (R n) closest to where a believes
the ground is. The chain then gives, in the chain's own frame (x, y level, z down, ground z = 0, the
first photo at height 1):

* heights: d_a = d_b (1 + (R n) . t)  ->  d_b = d_a / (1 + (R n) . t)       (the plane seen from a and b)
* positions: C_b = C_a + R_wa t d_b
* attitude: R_wb = R_wa R, then the minimal rotation that puts the observed ground normal n straight
  down (the ground fixes tilt at every photo: tilt does not drift, heading does).

Registration to the previous photo and the one before (``max_refs``) are fused (weights = inliers);
when no recent photo registers, the photo is bridged to the earlier photos nearest to where it is
predicted to be (``bridge_tries``). A photo that registers to none is placed by a constant-velocity
prediction (and counted as not registered).

While GPS is allowed (``--gps-until``) the chain is tied to the world by a similarity (Umeyama: scale =
the first photo's height in metres, heading, offset) fitted to the GPS fixes of the photos of the
current connected stretch; the estimate is the GPS there. After the last fix the estimate is the chain
mapped through the last similarity: pure visual odometry, with the scale from the height learned
while GPS was allowed, heading from the chain of homographies.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from visnav.geometry.rotations import dcm_to_euler
from visnav.log_schema import register_stream
from visnav.measurements import Frame, GpsSample, Health, NavCommand, NavEstimate, NavInit
from visnav.navigation.base import CommandDispatch
from visnav.vision.features import FeatureMatcher

register_stream("vo_photo", registered=("bool", "", "registered to an earlier photo (else placed by prediction)"),
                refs=("count", "", "earlier photos it was registered to"), inliers=("count", "", "homography inliers"),
                height=("chain units", "", "height above the ground in the first photo's heights"))

def _horizontal_covariance(var_h: float) -> np.ndarray:
    """(6, 6) covariance of (position, velocity) with ``var_h`` on north and east, NaN elsewhere."""
    C = np.full((6, 6), np.nan)
    C[:2, :2] = 0.0
    C[0, 0] = C[1, 1] = var_h
    return C


E3 = np.array([0.0, 0.0, 1.0])
#: the first photo's camera in the chain frame: nadir, image top = chain x (camera x -> y, camera y -> -x)
R_CHAIN0 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class VOConfig:
    method: str = "sift"
    work_width: int = 600  # photos are matched at this width [px]
    max_refs: int = 2  # recent photos fused per photo
    recent: int = 3  # how many of the latest photos are tried first
    bridge_tries: int = 100  # earlier photos tried (nearest to the prediction first) when no recent one registers
    overlap_tries: int = 2  # older photos near the new one (an earlier leg of the survey) also registered to it
    overlap_radius: float = 1.2  # ... within this horizontal distance in heights
    hold_height: float = 0.3  # per photo, the height is pulled this share toward the one learned while GPS was
    # allowed (a survey holds its altitude; 0: the chain's heights alone, which drift)
    min_segment_fixes: int = 3  # GPS photos of the current stretch the similarity needs (else all GPS photos)
    gps_match_s: float = 0.5  # a GPS fix this close in time to a photo belongs to it
    max_predict_s: float = 10.0  # a constant-velocity prediction goes no further (a long gap: a turn, a loiter)


@dataclass
class _Photo:
    t: float
    feats: object
    R: np.ndarray  # camera -> chain frame
    C: np.ndarray  # camera centre, chain frame (height units of the first photo)
    registered: bool  # placed by registration (else by prediction)
    refs: list = field(default_factory=list)  # (index, inliers) of the photos it was registered to
    segment: int = 0  # connected stretch (a photo placed by prediction starts a new one)
    gps: np.ndarray | None = None  # NED fix at the photo [m]
    P: np.ndarray | None = None  # world NED position [m] (GPS where it has one, else the chain through the similarity)


def _rot_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The minimal rotation taking unit vector u onto unit vector v (Rodrigues)."""
    u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
    c = float(u @ v)
    w = np.cross(u, v)
    s = float(np.linalg.norm(w))
    if s < 1e-12:
        return np.eye(3)
    k = w / s
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * Kx + (1 - c) * Kx @ Kx


def umeyama_2d(X: np.ndarray, Y: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Similarity Y ~ s R X + tau in the plane, least squares (Umeyama 1991, eqs. 40-42): (s, R, tau)."""
    mx, my = X.mean(axis=0), Y.mean(axis=0)
    Xc, Yc = X - mx, Y - my
    S = Yc.T @ Xc / len(X)
    U, D, Vt = np.linalg.svd(S)
    sign = np.diag([1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0])
    R = U @ sign @ Vt
    var = (Xc ** 2).sum() / len(X)
    s = float(np.trace(np.diag(D) @ sign) / var) if var > 0 else 1.0
    return s, R, my - s * R @ mx


class VONavigator(CommandDispatch):
    """Frame-only visual odometry of nadir photos, scaled and oriented by the GPS while it is allowed."""

    def __init__(self, camera, cfg: VOConfig | None = None, recorder=None, mount=None) -> None:
        self.cfg = cfg or VOConfig()
        self.camera = camera
        self.K = np.asarray(camera.K, float)
        self.mount = mount
        self.matcher = FeatureMatcher(self.cfg.method, work_width=self.cfg.work_width)
        self.recorder = recorder or (lambda *a, **k: None)
        self.photos: list[_Photo] = []
        self.gps: list[GpsSample] = []
        self.sim: tuple[float, np.ndarray, np.ndarray] | None = None  # chain xy -> world NE
        self.ground_d = 0.0  # world down of the ground [m] (GPS down + height)
        self.h_ref: float | None = None  # height above the ground learned while GPS was allowed [chain units]
        self.pairs_tried = 0
        self.bridged = 0
        self.notes: list[str] = []

    # ------------------------------------------------------------------------------------ messages
    def update(self, m) -> None:
        if isinstance(m, GpsSample):
            self.gps.append(m)
            if self.photos and self.photos[-1].gps is None and abs(m.t - self.photos[-1].t) <= self.cfg.gps_match_s:
                self.photos[-1].gps = np.asarray(m.position, float)
                self._fit()
        elif isinstance(m, Frame):
            self._frame(m)

    def initialize(self, init: NavInit) -> None:  # a survey has no explicit start: the GPS fixes tie the chain
        self.notes.append(f"initialize({init.source}) at t={init.t:.1f} s ignored: the vo navigator is tied to the "
                          "world by the GPS fixes")

    def _cmd_reset(self, t: float) -> None:
        self.__init__(self.camera, self.cfg, self.recorder, self.mount)

    # ----------------------------------------------------------------------------- registration
    def _relative(self, j: int, H: np.ndarray):
        """Photo b placed from photo j and H (b -> j pixels): (R_wb, C_b) in the chain frame, or None."""
        import cv2

        a = self.photos[j]
        _, Rs, ts, ns = cv2.decomposeHomographyMat(H, self.K)
        down_a = a.R.T @ E3
        best, score = None, -2.0
        for R, t, n in zip(Rs, ts, ns):
            n, t = n.ravel(), t.ravel()
            if n[2] <= 0:
                continue
            sc = float((R @ n) @ down_a)
            if sc > score:
                best, score = (R, t, n), sc
        if best is None or score < math.cos(math.radians(35)):
            return None
        R, t, n = best
        den = 1.0 + float((R @ n) @ t)
        h_a = -a.C[2]
        if den < 0.3:
            return None
        d_b = h_a / den
        C = a.C + a.R @ (t * d_b)
        C[2] = -d_b
        Rw = a.R @ R
        Rw = _rot_between(Rw @ n, E3) @ Rw  # the ground normal straight down: tilt from the ground
        return Rw, C

    def _predict(self, t: float) -> np.ndarray:
        ph = self.photos
        if len(ph) < 2:
            return ph[-1].C.copy()
        a, b = ph[-2], ph[-1]
        dt = b.t - a.t
        v = (b.C - a.C) / dt if dt > 0 else np.zeros(3)
        v[2] = 0.0  # the height is held
        return b.C + v * min(t - b.t, self.cfg.max_predict_s)

    def _frame(self, m: Frame) -> None:
        from scipy.spatial.transform import Rotation

        feats = self.matcher.detect(m.image)
        k = len(self.photos)
        gps = self._gps_at(m.t)
        if k == 0:
            self.photos.append(_Photo(m.t, feats, R_CHAIN0.copy(), np.array([0.0, 0.0, -1.0]), True, gps=gps))
            self._fit()
            return
        found, tried = [], set()

        def attempt(j: int) -> bool:
            tried.add(j)
            self.pairs_tried += 1
            pm = self.matcher.match(self.photos[j].feats, feats, self.K)
            if pm.ok and (rel := self._relative(j, pm.H)) is not None:
                found.append((j, pm.inliers, rel))
                return True
            return False

        for j in range(k - 1, max(-1, k - 1 - self.cfg.recent), -1):
            if attempt(j) and sum(self.photos[f[0]].registered for f in found) >= self.cfg.max_refs:
                break
        pred = self._predict(m.t)
        if not any(self.photos[f[0]].registered for f in found):
            # bridge: the registered earlier photos nearest to where this one is predicted
            cand = sorted((j for j in range(k) if j not in tried and self.photos[j].registered),
                          key=lambda j: np.linalg.norm(self.photos[j].C[:2] - pred[:2]))
            for j in cand[: self.cfg.bridge_tries]:
                if attempt(j):
                    self.bridged += 1
                    break
        reg = [f for f in found if self.photos[f[0]].registered]
        found = reg or found  # a photo placed by prediction is a reference only when nothing else registers
        if found and self.cfg.overlap_tries:  # an earlier leg seen again: register to it too (drift bounded there)
            here = found[0][2][1]
            h = -here[2]
            cand = sorted((j for j in range(k - self.cfg.recent) if j not in tried and self.photos[j].registered
                           and np.linalg.norm(self.photos[j].C[:2] - here[:2]) < self.cfg.overlap_radius * h),
                          key=lambda j: np.linalg.norm(self.photos[j].C[:2] - here[:2]))
            for j in cand[: self.cfg.overlap_tries]:
                attempt(j)
        last = self.photos[-1]
        if found:
            w = np.array([f[1] for f in found], float)
            C = (np.array([f[2][1] for f in found]) * w[:, None]).sum(axis=0) / w.sum()
            R = Rotation.from_matrix(np.array([f[2][0] for f in found])).mean(weights=w).as_matrix()
            seg = last.segment
            ph = _Photo(m.t, feats, R, C, True, [(f[0], f[1]) for f in found], seg, gps)
        else:
            ph = _Photo(m.t, feats, last.R.copy(), self._predict(m.t), False, [], last.segment + 1, gps)
        self.photos.append(ph)
        if self.sim is not None and self.cfg.hold_height > 0 and self.h_ref is not None:
            ph.C[2] += self.cfg.hold_height * (-self.h_ref - ph.C[2])
        self.recorder("vo_photo", m.t, registered=int(ph.registered), refs=len(ph.refs),
                      inliers=int(sum(r[1] for r in ph.refs)), height=float(-ph.C[2]))
        self._fit()

    def _gps_at(self, t: float) -> np.ndarray | None:
        if self.gps and abs(self.gps[-1].t - t) <= self.cfg.gps_match_s:
            return np.asarray(self.gps[-1].position, float)
        return None

    # ------------------------------------------------------------------------- tie to the world
    def _fit(self) -> None:
        """The similarity chain -> world from the GPS photos of the current stretch (else all), and the
        world positions of the photos."""
        ph = self.photos
        with_gps = [p for p in ph if p.gps is not None and p.registered]
        seg = [p for p in with_gps if p.segment == ph[-1].segment]
        use = seg if len(seg) >= self.cfg.min_segment_fixes else with_gps
        if len(use) >= 2:
            X = np.array([p.C[:2] for p in use])
            Y = np.array([p.gps[:2] for p in use])
            if np.ptp(Y, axis=0).max() > 1.0 and np.ptp(X, axis=0).max() > 1e-6:
                self.sim = umeyama_2d(X, Y)
                s = self.sim[0]
                self.ground_d = float(np.mean([p.gps[2] - s * p.C[2] for p in use]))  # ground down = d + height
                # the height above the ground while GPS is allowed: GPS altitude over the ground, chain units
                self.h_ref = float(np.mean([(self.ground_d - p.gps[2]) / s for p in use]))
        for p in ph:
            if p.gps is not None:
                p.P = p.gps
            elif self.sim is not None:
                s, R, tau = self.sim
                p.P = np.r_[s * R @ p.C[:2] + tau, self.ground_d + s * p.C[2]]

    # ------------------------------------------------------------------------------------ output
    def _world_attitude(self, p: _Photo) -> np.ndarray:
        if self.sim is None:
            return np.zeros(3)
        R2 = self.sim[1]
        Rz = np.eye(3)
        Rz[:2, :2] = R2
        Rcb = np.asarray(self.mount.R_cam_to_body, float) if self.mount is not None else R_CHAIN0
        return dcm_to_euler(Rz @ p.R @ Rcb.T)  # body -> world

    def photo_pose(self, i: int) -> tuple[np.ndarray, np.ndarray, float] | None:
        """Photo ``i`` in the world: (camera -> NED rotation, NED position [m], height above the ground [m]),
        None before the chain is tied to the world."""
        p = self.photos[i]
        if self.sim is None or p.P is None:
            return None
        s, R2 = self.sim[0], self.sim[1]
        Rz = np.eye(3)
        Rz[:2, :2] = R2
        return Rz @ p.R, np.asarray(p.P, float), float(-s * p.C[2])

    def chain_offset(self, a: int, b: int) -> np.ndarray | None:
        """Horizontal NE displacement from photo a to photo b by the VO chain alone (through the similarity)."""
        if self.sim is None:
            return None
        s, R2 = self.sim[0], self.sim[1]
        return s * R2 @ (self.photos[b].C[:2] - self.photos[a].C[:2])

    def estimate(self, t: float) -> NavEstimate:
        """The newest placed photo carried at the chain's velocity (the GPS before any photo is placed).
        Covariance: only the horizontal position has one, the last fix's sigma^2 while GPS ties the chain and
        +inf (no bound: the chain has no error model) after; height and velocity NaN (not modelled)."""
        placed = [p for p in self.photos if p.P is not None]
        g = self.gps[-1] if self.gps else None
        if not placed:
            if g is None:
                return NavEstimate(t, np.full(3, np.nan), np.full(3, np.nan), np.zeros(3), valid=False, source="vo")
            return NavEstimate(t, g.position + g.velocity * (t - g.t), np.asarray(g.velocity, float), np.zeros(3),
                               _horizontal_covariance(g.sigma**2), source="gps")
        b = placed[-1]
        a = placed[-2] if len(placed) > 1 else None
        v = (b.P - a.P) / (b.t - a.t) if a is not None and b.t > a.t else np.zeros(3)
        src = "gps" if b.gps is not None else "vo"  # (a photo tied to a fix: self.gps holds it)
        return NavEstimate(t, b.P + v * min(t - b.t, self.cfg.max_predict_s), v, self._world_attitude(b),
                           _horizontal_covariance(g.sigma**2 if src == "gps" else np.inf), source=src)

    def health(self, t: float) -> Health:
        h = Health(source="vo" if self.photos and self.photos[-1].gps is None else "gps",
                   tracking=bool(self.photos and self.photos[-1].registered))
        h.notes = list(self.notes)
        return h

    # ----------------------------------------------------------------------------- replay figures
    def replay_metrics(self) -> dict:
        """What a replay reports of the registration (``pairs_registered_share``: photos after the first that
        registered to the previous photo or, bridged, to an earlier one)."""
        ph = self.photos
        n = max(len(ph) - 1, 0)
        reg = sum(p.registered for p in ph[1:])
        consecutive = sum(any(r[0] == i for r in p.refs) for i, p in enumerate(ph[1:]))
        out = {"photos": len(ph), "pairs_registered_share": reg / n if n else float("nan"),
               "pairs_consecutive_share": consecutive / n if n else float("nan"), "photos_bridged": self.bridged,
               "pairs_tried": self.pairs_tried}
        if self.sim is not None:
            out["vo_scale_m"] = self.sim[0]  # metres per chain unit = the first photo's height above ground
        return out

    def command(self, request: NavCommand) -> None:  # noqa: D102 - CommandDispatch
        super().command(request)
