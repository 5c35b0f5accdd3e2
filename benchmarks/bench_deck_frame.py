"""The deck frame path per call, the current code against the references the tests keep (speed round 4).

    PYTHONPATH=src python benchmarks/bench_deck_frame.py [--seed N] [--rounds R]

Flies deck-moving once to collect its frames (the render's arguments, the images), then times on the same
inputs, in alternation, minimum over ``R`` rounds of thread CPU per call [µs]: the LED render (uint8, and the
float32 reference of ``tests/sensors/test_led_camera.py``), ``find_blobs`` (and the full-frame reference of
``tests/vision/test_blobs.py``), the undistortion of each frame's blob centroids (Python-float path and the
array path). Each pair is checked equal on every input first.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' reference implementations


def collect(seed: int):
    from visnav.scenarios.schema import load_scenario
    from visnav.sensors.led_camera import LedCamera
    from visnav.app.missions import make_simulation

    calls, orig = [], LedCamera.render

    def rec(self, *a):
        img = orig(self, *a)
        calls.append((a, img))
        return img

    LedCamera.render = rec
    try:
        make_simulation(load_scenario("deck-moving", seed=seed)).run()
    finally:
        LedCamera.render = orig
    return calls


def camera(seed: int):
    from visnav.scenarios.schema import load_scenario
    from visnav.sensors.led_camera import LedCamera

    c = load_scenario("deck-moving", seed=seed).sensors.camera
    return LedCamera(c.pinhole(), c.rotation(), np.asarray(c.position_m, float), np.random.default_rng(2),
                     noise_gray=c.noise_gray, centroid_noise_px=c.centroid_noise_px,
                     jitter_rng=np.random.default_rng(6))


def per_call(fn, inputs, rounds: int) -> float:
    best = np.inf
    for _ in range(rounds):
        t0 = time.thread_time()
        for x in inputs:
            fn(x)
        best = min(best, (time.thread_time() - t0) / len(inputs))
    return 1e6 * best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args()
    import visnav.geometry.camera as camera_mod
    from tests.sensors.test_led_camera import reference_render
    from tests.vision.test_blobs import _find_blobs_reference
    from visnav.vision.blobs import find_blobs

    calls = collect(a.seed)
    args, images = [c[0] for c in calls], [c[1] for c in calls]
    new_cam, ref_cam = camera(a.seed), camera(a.seed)
    for x in args:  # equal on every frame (the two cameras draw the same noise)
        assert np.array_equal(new_cam.render(*x), reference_render(ref_cam, *x))
    blobs = [find_blobs(im) for im in images]
    assert all(np.array_equal(b, _find_blobs_reference(im)) for b, im in zip(blobs, images))
    pin = new_cam.camera
    xd = [np.column_stack([(b[:, 0] - pin.cx) / pin.fx, (b[:, 1] - pin.cy) / pin.fy]) for b in blobs if len(b)]
    few = [pin.undistort_normalized(x) for x in xd]
    keep = camera_mod._UNDISTORT_FEW
    camera_mod._UNDISTORT_FEW = 0
    assert all(np.allclose(f, pin.undistort_normalized(x), rtol=1e-13, atol=1e-15, equal_nan=True) for f, x in zip(few, xd))
    camera_mod._UNDISTORT_FEW = keep

    rows = []
    for name, new, ref, inputs in (
            ("LED render (uint8 / float32 reference)", lambda x: new_cam.render(*x),
             lambda x: reference_render(ref_cam, *x), args),
            ("find_blobs (row/column box / full-frame reference)", find_blobs, _find_blobs_reference, images),
            ("undistort a frame's centroids (floats / array path)", pin.undistort_normalized, None, xd)):
        t_new, t_ref = [], []
        for _ in range(2):  # alternate
            t_new.append(per_call(new, inputs, a.rounds))
            if ref is None:
                camera_mod._UNDISTORT_FEW = 0
                t_ref.append(per_call(new, inputs, a.rounds))
                camera_mod._UNDISTORT_FEW = keep
            else:
                t_ref.append(per_call(ref, inputs, a.rounds))
        rows.append((name, min(t_ref), min(t_new)))
    import os

    print(f"deck-moving seed {a.seed}: {len(args)} frames, {len(xd)} with blobs; load average {os.getloadavg()[0]:.2f}")
    print("| per call | before µs | after µs | ratio |\n|---|---:|---:|---:|")
    for name, r, n in rows:
        print(f"| {name} | {r:.1f} | {n:.1f} | {r / n:.2f}x |")


if __name__ == "__main__":
    main()
