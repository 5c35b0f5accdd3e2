"""Real frames through the vision front ends (issue 28 item 4): figures for ``docs/real-data.md``.

- ``klt_on_frames``: the KLT tracker (``vision/klt.py``) over a real image sequence (EuRoC cam0):
  track lengths, survival of the first frame's features, and the sub-pixel agreement of each
  step with an independent OpenCV ``calcOpticalFlowPyrLK`` run (wider window, one more pyramid
  level, tighter stop) from the same points.
- ``palace_on_frames``: the PALACE tracker (Förstner point, ``vision/interest.py``; Moravec PNCC
  tracker, ``vision/correlation.py``, configured as ``navigation/palace.py`` builds it) on the same
  frames: several points at once, each re-seeded when lost; lengths, survival, the per-step
  displacement against OpenCV's LK from the same previous position, and how many picked points
  are not distinct (their template matches its own neighbourhood almost as well as itself,
  ``vision.correlation.self_coherence``).
- ``pad_on_photos``: the three-circle pad detector (``vision/pad.py``) on real photos that hold no
  such pad: every pose it returns is a false pose; per-frame time at the photo's size.
  ``pad_on_tiles``: the same on 2x2 mosaics of the photos with rings (3+ real rings per frame).

No synthetic input: every figure is measured on the files given (``../shared/data``).
"""

from __future__ import annotations

import csv
import time
from pathlib import Path

import cv2
import numpy as np

from visnav.vision.correlation import PnccTracker, self_coherence
from visnav.vision.interest import forstner_top_k
from visnav.vision.klt import KltTracker
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.pad import PadLayout
from visnav.vision.pad import PadDetector
import itertools

__all__ = ["load_euroc_frames", "klt_on_frames", "palace_on_frames", "pad_on_photos", "pad_on_tiles", "marker_photos"]

#: The reference LK: independent settings from the KLT tracker's (21 px window, 3 levels, 20 iterations).
REFERENCE_LK = dict(winSize=(31, 31), maxLevel=4,
                    criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 0.001))


def load_euroc_frames(folder, limit: int | None = None, step: int = 1) -> tuple[np.ndarray, list[np.ndarray]]:
    """(t [s], grey frames) of an EuRoC/ASL camera folder (``mav0/cam0`` or the dataset root):
    ``data.csv`` (timestamp [ns], file name) and the images under ``data/``. ``step`` keeps every
    n-th frame, ``limit`` the first frames kept."""
    root = Path(folder)
    for cand in (root, root / "cam0", root / "mav0" / "cam0"):
        if (cand / "data.csv").is_file():
            root = cand
            break
    else:
        raise FileNotFoundError(f"{folder}: no EuRoC camera folder (data.csv) found")
    rows = []
    with (root / "data.csv").open() as f:
        for r in csv.reader(f):
            if r and not r[0].startswith("#"):
                rows.append((int(r[0]), r[1].strip()))
    rows = rows[::max(int(step), 1)][:limit]
    imgs = []
    for _, name in rows:
        img = cv2.imread(str(root / "data" / name), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise ValueError(f"{root / 'data' / name}: not a readable image")
        imgs.append(img)
    return np.array([ns for ns, _ in rows], float) * 1e-9, imgs


def _reference_flow(prev: np.ndarray, img: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV LK (``REFERENCE_LK``) from ``pts`` in ``prev`` to ``img`` with a forward-backward check
    (< 0.5 px): (positions, ok)."""
    p0 = np.asarray(pts, np.float32).reshape(-1, 1, 2)
    p1, st, _ = cv2.calcOpticalFlowPyrLK(prev, img, p0, None, **REFERENCE_LK)
    pb, stb, _ = cv2.calcOpticalFlowPyrLK(img, prev, p1, None, **REFERENCE_LK)
    fb = np.linalg.norm((pb - p0).reshape(-1, 2), axis=1)
    return p1.reshape(-1, 2).astype(float), (st.ravel() == 1) & (stb.ravel() == 1) & (fb < 0.5)


def _length_stats(lengths: list[int], n_frames: int) -> dict:
    a = np.asarray(lengths, float)
    return dict(tracks=int(a.size), length_median=float(np.median(a)) if a.size else float("nan"),
                length_mean=float(a.mean()) if a.size else float("nan"),
                length_max=int(a.max()) if a.size else 0, frames=int(n_frames))


def klt_on_frames(frames: list[np.ndarray], **tracker_kw) -> dict:
    """The KLT tracker over ``frames``: track lengths in frames (a track is a feature followed from
    the frame it was detected in until lost or the end), the share of frame 0's features still
    tracked after 5/10/20/all frames, features per frame, and per step the distance between the
    tracker's new position and the reference LK's from the same point (median, 90th percentile)."""
    if len(frames) < 2:
        raise ValueError(f"need at least 2 frames, got {len(frames)}")
    trk = KltTracker(**tracker_kw)
    trk.track(frames[0])
    first = {tuple(p) for p in np.asarray(trk.pts, np.float32)}
    age = {p: 0 for p in first}  # feature position in the last frame -> frames it has been tracked
    origin0 = {p: p for p in first}  # -> its frame-0 feature (for survival)
    ended: list[int] = []
    alive0 = {}
    diffs, per_frame = [], []
    for k in range(1, len(frames)):
        pairs = trk.track(frames[k])
        per_frame.append(len(pairs.prev))
        if len(pairs.prev):
            ref, ok = _reference_flow(frames[k - 1], frames[k], pairs.prev)
            diffs.extend(np.linalg.norm(pairs.curr[ok] - ref[ok], axis=1).tolist())
        new_age, new_origin = {}, {}
        seen = set()
        for p, c in zip(np.asarray(pairs.prev, np.float32), np.asarray(pairs.curr, np.float32)):
            kp, kc = tuple(p), tuple(c)
            seen.add(kp)
            new_age[kc] = age.get(kp, 0) + 1
            if kp in origin0:
                new_origin[kc] = origin0[kp]
        ended.extend(a for p, a in age.items() if p not in seen)
        for p in np.asarray(trk.pts, np.float32):  # top-up features start at age 0
            new_age.setdefault(tuple(p), 0)
        age, origin0 = new_age, new_origin
        alive0[k] = len(origin0)
    ended.extend(age.values())
    lengths = [a for a in ended if a > 0]
    n0 = max(len(first), 1)
    surv = {f"survival_{n}": alive0[n] / n0 for n in (5, 10, 20) if n in alive0}
    surv["survival_all"] = alive0[len(frames) - 1] / n0
    d = np.asarray(diffs)
    return dict(_length_stats(lengths, len(frames)), features_first=len(first),
                features_per_frame_median=float(np.median(per_frame)), **surv,
                lk_steps=int(d.size), lk_diff_median_px=float(np.median(d)) if d.size else float("nan"),
                lk_diff_p90_px=float(np.percentile(d, 90)) if d.size else float("nan"))


def palace_on_frames(frames: list[np.ndarray], n_points: int = 20, template_px: int = 21, search_radius_px: int = 30,
                     min_coherence: float = 0.5, mode: str = "thesis", subpixel: bool = False, feature_size: int = 7,
                     min_isotropy: float = 0.2, max_self_coherence: float = 1.0, exclude_px: int = 3, jump_px: float = 2.0) -> dict:
    """The PALACE tracker on ``frames``: ``n_points`` Förstner points of frame 0 (strongest first,
    ``min_distance`` one template apart; with ``max_self_coherence`` < 1 the non-distinct ones
    skipped, as ``navigation/palace.py`` does), each followed by its own PNCC tracker; a lost
    point is replaced by the strongest free Förstner point of that frame. Returns track lengths,
    the survival of frame 0's points, reasons of loss, per step the distance between the tracker's
    displacement and the reference LK's from the tracker's previous position (median, 90th
    percentile, max; ``lk_diff_*``; steps and tracks more than ``jump_px`` off it: ``jump_steps``,
    ``tracks_jumped``: the tracker jumped to another match), and the self-coherence of each picked point (``nondistinct``: how
    many picked points had a second match >= 0.9 within the search window)."""
    if len(frames) < 2:
        raise ValueError(f"need at least 2 frames, got {len(frames)}")
    kw = dict(template_size=template_px, search_radius=search_radius_px, subpixel=subpixel,
              min_coherence=min_coherence, mode=mode)
    half = template_px // 2
    border = half + search_radius_px

    def pick(img: np.ndarray, k: int, taken: list[tuple[float, float]]) -> list:
        exclude = [(x, y, float(template_px)) for x, y in taken] or None
        cands = forstner_top_k(img, 4 * k, feature_size=feature_size, min_isotropy=min_isotropy, border=border,
                               exclude=exclude, min_distance=float(template_px))
        out = []
        for p in cands:
            sc = self_coherence(img, p.x, p.y, template_px, search_radius_px, exclude_px)
            selfc.append(sc)
            if sc > max_self_coherence:
                continue
            out.append(p)
            if len(out) == k:
                break
        return out

    selfc: list[float] = []
    tracks = []  # [tracker, length, from frame 0]
    for p in pick(frames[0], n_points, []):
        t = PnccTracker(**kw)
        t.init(frames[0], p.x, p.y)
        tracks.append([t, 0, True])
    n0 = max(len(tracks), 1)
    lengths, reasons, diffs, alive0, jumped = [], {}, [], {}, set()
    for k in range(1, len(frames)):
        img = frames[k]
        prev = np.array([[t.x, t.y] for t, _, _ in tracks], float)
        ref, rok = _reference_flow(frames[k - 1], img, prev) if len(prev) else (prev, np.zeros(0, bool))
        keep = []
        for i, tr in enumerate(tracks):
            res = tr[0].track(img)
            if res.ok:
                tr[1] += 1
                if rok[i]:
                    diffs.append(float(np.hypot(res.x - ref[i, 0], res.y - ref[i, 1])))
                    if diffs[-1] > jump_px:
                        jumped.add(id(tr))
                keep.append(tr)
            else:
                reasons[res.reason] = reasons.get(res.reason, 0) + 1
                lengths.append(tr[1])
        tracks = keep
        alive0[k] = sum(1 for tr in tracks if tr[2])
        need = n_points - len(tracks)
        if need > 0:
            for p in pick(img, need, [(tr[0].x, tr[0].y) for tr in tracks]):
                t = PnccTracker(**kw)
                t.init(img, p.x, p.y)
                tracks.append([t, 0, False])
    lengths.extend(tr[1] for tr in tracks)
    d = np.asarray(diffs)
    s = np.asarray(selfc)
    surv = {f"survival_{n}": alive0[n] / n0 for n in (5, 10, 20) if n in alive0}
    surv["survival_all"] = alive0[len(frames) - 1] / n0
    return dict(_length_stats([x for x in lengths if x > 0], len(frames)), points_first=n0, **surv,
                lost=reasons, lk_steps=int(d.size),
                lk_diff_median_px=float(np.median(d)) if d.size else float("nan"),
                lk_diff_p90_px=float(np.percentile(d, 90)) if d.size else float("nan"),
                lk_diff_max_px=float(d.max()) if d.size else float("nan"),
                jump_steps=int(np.sum(d > jump_px)), tracks_jumped=len(jumped),
                picked_self_coherence_median=float(np.median(s)) if s.size else float("nan"),
                nondistinct=int(np.sum(s >= 0.9)), candidates=int(s.size))


def marker_photos(folder) -> list[Path]:
    """The photos of a ``markers_downward``-style folder (``train/images``, ``val/images``; any
    .jpg/.png below ``folder``), sorted."""
    root = Path(folder)
    if not root.is_dir():
        raise FileNotFoundError(f"{folder}: not a folder")
    return sorted(p for p in root.rglob("*") if p.suffix.lower() in (".jpg", ".jpeg", ".png"))


def pad_on_photos(paths, detector=None, size: tuple[int, int] = (640, 480)) -> dict:
    """The pad detector on photos without a three-circle pad: every pose is a false pose. Frames
    are resized to ``size`` when they differ; ``detector`` defaults to ``PadDetector(PadLayout(),
    K)`` with f = the image width (a 53° field of view, a typical downward camera). Returns the
    number of photos, false poses (with the photo names), rings found per photo, the reasons the
    detector gave, and the per-frame time of ``detect`` (mean, median, max, in ms; wall clock ``ms_*``
    and this process's CPU time ``cpu_ms_*``, all threads: on a loaded machine the wall clock waits)."""

    w, h = size
    det = detector or PadDetector(PadLayout(), PinholeCamera.ideal(w, h, float(w)).K)
    times, cpu, rings, reasons, false = [], [], [], {}, []
    for p in paths:
        img = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise ValueError(f"{p}: not a readable image")
        if img.shape != (h, w):
            img = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
        t0, c0 = time.perf_counter(), time.process_time()
        d = det.detect(img)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        rings.append(len(d.rings))
        if d.pose is not None:
            false.append(Path(p).name)
        else:
            key = d.reason if "rings" not in d.reason else ("< 3 rings" if len(d.rings) < 3 else d.reason)
            reasons[key] = reasons.get(key, 0) + 1
    t = np.asarray(times) * 1e3
    r = np.asarray(rings)
    return dict(photos=len(t), false_poses=len(false), false_pose_photos=false, reasons=reasons,
                rings_median=float(np.median(r)) if r.size else float("nan"), rings_max=int(r.max()) if r.size else 0,
                photos_with_3_rings=int(np.sum(r >= 3)),
                ms_mean=float(t.mean()) if t.size else float("nan"),
                ms_median=float(np.median(t)) if t.size else float("nan"),
                ms_max=float(t.max()) if t.size else float("nan"),
                cpu_ms_mean=float(np.mean(cpu) * 1e3) if cpu else float("nan"),
                cpu_ms_median=float(np.median(cpu) * 1e3) if cpu else float("nan"),
                cpu_ms_max=float(np.max(cpu) * 1e3) if cpu else float("nan"))


def pad_on_tiles(paths, detector=None, per_tile: int = 4, limit: int = 300, size: tuple[int, int] = (640, 480)) -> dict:
    """A harder case for the pad detector's validation than single photos: 2x2 mosaics of the
    photos in which the ring detector found a ring (each photo at half size), so that three or more
    real rings of *different* markers are in one frame and reach the association (radius ratio,
    right isosceles triangle, 27-point homography residual, camera above the plane, ambiguity).
    Every pose is false. The first ``limit`` combinations of ``per_tile`` such photos (sorted)."""


    if per_tile != 4:
        raise ValueError(f"per_tile must be 4 (a 2x2 mosaic), got {per_tile}")
    w, h = size
    det = detector or PadDetector(PadLayout(), PinholeCamera.ideal(w, h, float(w)).K)
    small = []
    for p in paths:
        img = cv2.resize(cv2.imread(str(p), cv2.IMREAD_GRAYSCALE), (w, h), interpolation=cv2.INTER_AREA)
        if det.detect(img).rings:
            small.append(cv2.resize(img, (w // 2, h // 2), interpolation=cv2.INTER_AREA))
    false, n3, reasons, n = 0, 0, {}, 0
    for c in itertools.islice(itertools.combinations(range(len(small)), 4), limit):
        tile = np.vstack([np.hstack([small[c[0]], small[c[1]]]), np.hstack([small[c[2]], small[c[3]]])])
        d = det.detect(tile)
        n += 1
        n3 += len(d.rings) >= 3
        false += d.pose is not None
        key = "pose" if d.pose is not None else (d.reason if len(d.rings) >= 3 else "< 3 rings")
        reasons[key] = reasons.get(key, 0) + 1
    return dict(photos_with_rings=len(small), tiles=n, tiles_with_3_rings=int(n3), false_poses=int(false),
                reasons=reasons)
