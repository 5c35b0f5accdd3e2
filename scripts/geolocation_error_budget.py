"""Error budget of the map-based geo-location (seed 002 §7.2, Fig. 7.2) from the logs of mav-geolocation runs.

For every sample the ray through the tracked pixel is intersected with flat ground again, with one input
at a time taken from the telemetry (what the ground station had) and the others from the truth logged
beside it (the aircraft's position, yaw and height at the frame's instant, the camera's true tilt from
the gimbal): what each error source alone does to the samples and to their mean (the RLS of equally
weighted samples, without its gating).

    PYTHONPATH=src python scripts/geolocation_error_budget.py RUN_DIR [RUN_DIR ...] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

SOURCES = ("telemetry (all)", "GPS position", "GPS heading", "baro height", "camera tilt (gimbal)", "none (tracker)")


def budget(run_dir: Path) -> dict:
    from visnav.geometry.rotations import euler_to_dcm
    from visnav.scenarios.schema import load_scenario
    from visnav.sensors.gimbal import PitchRollGimbal
    from visnav.app.geoloc_parts import mav_camera
    from visnav.flightlog import FlightLog
    from visnav.vision.geolocation_registration import map_based_target, nadir_dcm

    log = FlightLog.from_hdf5(run_dir / "log.h5")
    sc = load_scenario(str(run_dir / "scenario.toml"))
    cam = mav_camera(sc.sensors.camera)
    s, f = log.get("sample"), log.get("frame")
    target = np.asarray(log.get("target")["position"])[0]
    ft = np.asarray(f["t"])
    out = {k: [] for k in SOURCES}
    along = []  # the GPS position error along the true track (latency: the fix describes an earlier instant)
    tr = log.get("truth")
    tt, vel = np.asarray(tr["t"]), np.asarray(tr["velocity"])
    for k in range(len(s["t"])):
        i = int(np.argmin(np.abs(ft - s["t"][k])))
        p = np.asarray(f["position"][i])
        yaw = float(f["yaw"][i])
        tilt = [float(f["cam_roll_error"][i]), float(f["cam_pitch_error"][i])]
        C_true = euler_to_dcm(np.array([*tilt, yaw])) @ PitchRollGimbal.R_CAM_BODY
        uv, gps, psi = np.asarray(s["uv"][k]), np.asarray(s["gps"][k]), float(s["heading_tel"][k])
        mb = np.asarray(s["map"][k])
        # the baro height the ground station used: solve the logged map-based sample for it
        d = nadir_dcm(psi) @ cam.unproject(uv.reshape(1, 2))[0]
        off = d[:2] / d[2]
        baro = float(np.dot(mb - gps, off) / np.dot(off, off))
        h = -float(p[2])

        def ray(pos, height, C):
            return map_based_target(cam, uv, pos, height, 0.0, C)

        v = np.array([np.interp(s["t"][k], tt, vel[:, j]) for j in range(2)])
        along.append(float(np.dot(gps - p[:2], v / np.linalg.norm(v))) / float(np.linalg.norm(v)))
        out["telemetry (all)"].append(mb)
        out["GPS position"].append(ray(gps, h, C_true))
        out["GPS heading"].append(ray(p[:2], h, euler_to_dcm(np.array([*tilt, psi])) @ PitchRollGimbal.R_CAM_BODY))
        out["baro height"].append(ray(p[:2], baro, C_true))
        out["camera tilt (gimbal)"].append(ray(p[:2], h, nadir_dcm(yaw)))
        out["none (tracker)"].append(ray(p[:2], h, C_true))
    res = {}
    for k, v in out.items():
        e = np.asarray(v) - target
        res[k] = {"sample_median_m": float(np.median(np.linalg.norm(e, axis=1))),
                  "mean_error_m": float(np.linalg.norm(e.mean(axis=0))), "mean_offset_ne": e.mean(axis=0).tolist()}
    res["gps_lag_s"] = -float(np.mean(along))  # the GPS error along the track in seconds of flight
    return res


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--json")
    a = ap.parse_args()
    rows = {}
    for r in a.runs:
        rows[r] = budget(Path(r))
        print(r)
        for k, v in rows[r].items():
            if k in SOURCES:
                print(f"  {k:22s} sample median {v['sample_median_m']:6.2f} m   mean of samples {v['mean_error_m']:6.2f} m")
        print(f"  GPS position error along the track: {rows[r]['gps_lag_s']:.2f} s of flight behind")
    if len(rows) > 1:
        print("median over runs")
        for k in SOURCES:
            print(f"  {k:22s} sample median {np.median([r[k]['sample_median_m'] for r in rows.values()]):6.2f} m   "
                  f"mean of samples {np.median([r[k]['mean_error_m'] for r in rows.values()]):6.2f} m")
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
