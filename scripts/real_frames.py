"""Real frames through the vision front ends: the figures of docs/real-data.md (issue 28 item 4).

    python scripts/real_frames.py [DATA_DIR] [--json]

DATA_DIR defaults to ``../shared/data`` beside the repository. Prints the KLT and PALACE tracker rows
on EuRoC V1_01 cam0 (all 95 frames at 20 Hz, and every 4th frame: 5 Hz) and the pad detector on every
``markers_downward`` photo.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from visnav.analysis.real_frames import (klt_on_frames, load_euroc_frames, marker_photos, pad_on_photos,
                                         pad_on_tiles, palace_on_frames)


def main(argv: list[str]) -> dict:
    args = [a for a in argv if not a.startswith("--")]
    data = Path(args[0]) if args else Path(__file__).resolve().parents[1].parent / "shared" / "data"
    out: dict = {"trackers": []}
    _, frames = load_euroc_frames(data / "euroc_v1_01")
    for step in (1, 4):
        f = frames[::step]
        rate = 20 / step
        out["trackers"].append(dict(tracker="KLT (vision/klt.py, 50 features)", rate_hz=rate, **klt_on_frames(f)))
        for name, kw in (("PALACE thesis (integer PNCC)", {}), ("PALACE sub-pixel PNCC", dict(subpixel=True))):
            for guard in (1.0, 0.9):
                r = palace_on_frames(f, n_points=40, max_self_coherence=guard, **kw)
                out["trackers"].append(dict(tracker=f"{name}, guard {'off' if guard >= 1 else guard}",
                                            rate_hz=rate, **r))
    out["pad"] = pad_on_photos(marker_photos(data / "markers_downward"))
    out["pad_tiles"] = pad_on_tiles(marker_photos(data / "markers_downward"))
    return out


def markdown(out: dict) -> str:
    lines = ["| tracker | rate Hz | tracks | median length | survival (all) | median Δ vs LK px | p90 px | max px "
             "| tracks jumped > 2 px |", "|---|---|---|---|---|---|---|---|---|"]
    for r in out["trackers"]:
        lines.append(f"| {r['tracker']} | {r['rate_hz']:g} | {r['tracks']} | {r['length_median']:.0f} | "
                     f"{r['survival_all']:.2f} | {r['lk_diff_median_px']:.3f} | {r['lk_diff_p90_px']:.3f} | "
                     f"{r.get('lk_diff_max_px', float('nan')):.2f} | {r.get('tracks_jumped', '-')} |")
    p = out["pad"]
    lines += ["", f"pad detector: {p['photos']} photos, {p['false_poses']} false poses, reasons {p['reasons']}, "
              f"rings per photo median {p['rings_median']:.0f} max {p['rings_max']}; per frame (640x480) "
              f"mean {p['ms_mean']:.1f} ms, median {p['ms_median']:.1f} ms, max {p['ms_max']:.1f} ms",
              f"2x2 mosaics of the photos with rings: {out['pad_tiles']}"]
    return "\n".join(lines)


if __name__ == "__main__":
    res = main(sys.argv[1:])
    print(json.dumps(res, indent=1, default=str) if "--json" in sys.argv else markdown(res))
