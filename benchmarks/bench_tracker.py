"""Benchmark: PNCC tracker (seed 000 Alg. 2) vs cv2.matchTemplate, and the Förstner operator.

Run: ``PYTHONPATH=src python benchmarks/bench_tracker.py``. Prints a markdown table; ``main()``
returns the numbers as a dict (seconds per call, medians over repeats, plus ratios).

Thesis case: 640x480 uint8 frames, 21x21 template, +-30 px search (61x61 candidate centres).
The reference is ``cv2.matchTemplate(TM_CCOEFF_NORMED)`` + ``cv2.minMaxLoc`` on the same
81x81 search windows and templates, timed in the same process.
"""

from __future__ import annotations

import datetime
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from visnav.vision.correlation import PnccTracker, pncc  # noqa: E402
from visnav.vision.interest import forstner  # noqa: E402

W, H = 640, 480
TEMPLATE, RADIUS = 21, 30


def _frames(n: int, rng: np.random.Generator) -> tuple[list[np.ndarray], np.ndarray]:
    """n camera frames of a textured ground moving by integer random steps (|step| <= 6 px)."""
    tex = cv2.GaussianBlur(rng.normal(0.0, 1.0, (H + 200, W + 200)).astype(np.float32), (0, 0), 1.5)
    tex = cv2.normalize(tex, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    steps = rng.integers(-6, 7, (n, 2))
    steps[0] = 0
    pos = np.cumsum(steps, axis=0)
    pos -= pos.min(axis=0)
    pos = np.minimum(pos, 199)
    return [tex[y : y + H, x : x + W] for x, y in pos], pos


def _median_time(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def _track_time(frames: list[np.ndarray], repeats: int, **kw) -> tuple[float, list[tuple[int, int]]]:
    """Median seconds per PnccTracker.track call; also the integer points it visited."""
    per_frame, points = [], []
    for _ in range(repeats):
        t = PnccTracker(template_size=TEMPLATE, search_radius=RADIUS, **kw)
        t.init(frames[0], W // 2, H // 2)
        pts = [(W // 2, H // 2)]
        for f in frames[1:]:
            t0 = time.perf_counter()
            r = t.track(f)
            per_frame.append(time.perf_counter() - t0)
            pts.append((int(round(r.x)), int(round(r.y))))
        points = pts
    return float(np.median(per_frame)), points


def main(n_frames: int = 60, repeats: int = 5, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    frames, pos = _frames(n_frames, rng)
    out: dict[str, float | str] = {
        "date": datetime.date.today().isoformat(),
        "machine": f"{platform.machine()} {platform.processor() or platform.system()}",
        "python": platform.python_version(),
        "opencv": cv2.__version__,
        "opencv_threads": cv2.getNumThreads(),
    }
    out["track_thesis_s"], pts = _track_time(frames, repeats)
    # Sanity: the scene moved by pos, so a ground point at the centre appears at centre - (pos - pos0).
    truth = np.array([W // 2, H // 2]) - (pos - pos[0])
    out["track_exact"] = bool(np.array_equal(np.array(pts), truth))
    out["track_subpixel_s"], _ = _track_time(frames, repeats, subpixel=True)
    out["track_anchored_s"], _ = _track_time(frames, repeats, mode="anchored")

    # The windows the thesis tracker searched: around the previous point, template from the previous frame.
    h, s = TEMPLATE // 2, RADIUS + TEMPLATE // 2
    pairs = []
    for i in range(1, len(frames)):
        px, py = pts[i - 1]
        pairs.append((frames[i][py - s : py + s + 1, px - s : px + s + 1], frames[i - 1][py - h : py + h + 1, px - h : px + h + 1]))

    def run_cv() -> None:
        for win, tm in pairs:
            cv2.minMaxLoc(cv2.matchTemplate(win, tm, cv2.TM_CCOEFF_NORMED))

    def run_pncc() -> None:
        for win, tm in pairs:
            np.argmax(pncc(win, tm))

    out["matchtemplate_s"] = _median_time(run_cv, repeats) / len(pairs)
    out["pncc_s"] = _median_time(run_pncc, repeats) / len(pairs)
    out["ratio_track_vs_cv"] = out["track_thesis_s"] / out["matchtemplate_s"]
    out["ratio_pncc_vs_cv"] = out["pncc_s"] / out["matchtemplate_s"]

    frame = frames[0]
    out["forstner_full_s"] = _median_time(lambda: forstner(frame), repeats * 4)
    cx, cy = W // 2, H // 2
    region = (cx - 100, cy - 100, cx + 100, cy + 100)
    out["forstner_region200_s"] = _median_time(lambda: forstner(frame, region=region), repeats * 4)

    ms = lambda k: f"{1e3 * out[k]:.3f}"  # noqa: E731
    print(f"visnav tracker benchmark, {out['date']}, {out['machine']}, Python {out['python']},")
    print(f"OpenCV {out['opencv']} ({out['opencv_threads']} threads); 640x480 uint8, 21x21 template, +-30 px\n")
    print(f"tracker followed the integer motion exactly: {out['track_exact']}\n")
    print("| operation | ms per call | vs matchTemplate |")
    print("|---|---:|---:|")
    print(f"| cv2.matchTemplate(TM_CCOEFF_NORMED) + minMaxLoc, 81x81 window | {ms('matchtemplate_s')} | 1.00 |")
    print(f"| pncc() + argmax, same windows | {ms('pncc_s')} | {out['ratio_pncc_vs_cv']:.2f} |")
    print(f"| PnccTracker.track, thesis mode | {ms('track_thesis_s')} | {out['ratio_track_vs_cv']:.2f} |")
    for key, name in (("track_subpixel_s", "subpixel=True"), ("track_anchored_s", 'mode="anchored"')):
        print(f"| PnccTracker.track, {name} | {ms(key)} | {out[key] / out['matchtemplate_s']:.2f} |")
    print(f"| forstner(), full 640x480 frame | {ms('forstner_full_s')} | |")
    print(f"| forstner(), 200x200 region | {ms('forstner_region200_s')} | |")
    return out


if __name__ == "__main__":
    main()
