"""The same seed of mav-geolocation gives the same bits in every process.

The registration's edge images went through ``cv2.magnitude``, which OpenCV hands to IPP; IPP's result
(within 2 ulp) depends on where the output buffer lies (its address mod 64 bytes), that is on the heap of
the process, so two runs of one seed differed at ~1e-7 in the registrations and ~1e-8 in the metrics.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

from visnav.vision.geolocation_registration import sobel_edges

# a short flight (the full map: its reference edge image is big enough to come off the heap)
SHORT = ["mission.max_samples=6", "run.duration_s=40"]

_CHILD = """
import json, sys
import numpy as np
from visnav.scenarios.schema import load_scenario
from visnav.app.missions import make_simulation
r = make_simulation(load_scenario("mav-geolocation", json.loads(sys.argv[2]), seed=1)).run()
assert r.error is None, r.error
arrays = {f"{s}/{k}": v for s in r.log.streams() for k, v in r.log.get(s).items() if v.dtype != object}
m = {k: v for k, v in r.metrics.items() if k not in ("wall_time_s", "real_time_factor")}
arrays["__metrics__"] = np.array(json.dumps(m, default=str, sort_keys=True))
np.savez(sys.argv[1], **arrays)
"""


def _run(out: Path, hashseed: str) -> dict:
    src = str(Path(__file__).resolve().parents[2] / "src")
    env = dict(os.environ, PYTHONHASHSEED=hashseed,
               PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]))
    p = subprocess.run([sys.executable, "-c", _CHILD, str(out), json.dumps(SHORT)], env=env,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-3000:]
    with np.load(out) as z:
        return {k: z[k] for k in z.files}


def test_same_seed_same_bits_in_two_processes(tmp_path):
    a = _run(tmp_path / "a.npz", "1")
    b = _run(tmp_path / "b.npz", "2")
    assert set(a) == set(b)
    assert len(a["sample/t"]) >= 5  # registrations took place
    differ = [k for k in sorted(a) if a[k].tobytes() != b[k].tobytes() or a[k].shape != b[k].shape]
    assert not differ, f"not bit-identical across processes: {differ}"


def _at(a: np.ndarray, offset: int) -> np.ndarray:
    """A copy of ``a`` whose data starts ``offset`` bytes past a 64-byte boundary."""
    buf = np.empty(a.nbytes + 128, np.uint8)
    s = (-buf.ctypes.data) % 64 + offset
    v = buf[s : s + a.nbytes].view(a.dtype).reshape(a.shape)
    v[...] = a
    return v


def test_sobel_edges_is_the_correctly_rounded_magnitude():
    """float32 sqrt(gx^2 + gy^2), each operation rounded once: what numpy gives on any SIMD path and
    any address (IPP's magnitude is off by up to 2 ulp on some elements, which ones depending on the
    address of its output)."""
    rng = np.random.default_rng(5)
    img = cv2.GaussianBlur(rng.integers(0, 256, (240, 320)).astype(np.uint8), (0, 0), 1.5)
    g = img.astype(np.float32)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3).astype(np.float64)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3).astype(np.float64)
    # gx, gy are small integers here: gx^2 + gy^2 is exact in float64, its sqrt rounded once to float32
    # equals the float32 sqrt of the (exact) float32 sum
    want = np.sqrt(gx * gx + gy * gy).astype(np.float32)
    for off in (0, 4, 8, 16, 36):
        got = sobel_edges(_at(img, off))
        assert got.dtype == np.float32
        assert got.tobytes() == want.tobytes(), off
