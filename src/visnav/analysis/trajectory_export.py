"""Trajectory exports: TUM, CSV, and GeoJSON / KML in latitude-longitude when a geodetic origin is known."""

from __future__ import annotations

import json
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from visnav.analysis.trajectory_eval import Trajectory
from visnav.geometry.frames import LocalTangentPlane
from visnav.io.tum import write_tum_quat


def write_tum_file(path: str | Path, traj: Trajectory, frame: str = "NED world, body FRD") -> Path:
    """TUM (``timestamp tx ty tz qx qy qz qw``), 9 decimals, the frame named in the header."""
    write_tum_quat(path, traj.t, traj.p, traj.q, frame, decimals=9)
    return Path(path)


def write_csv(path: str | Path, traj: Trajectory, extra: dict | None = None) -> Path:
    """CSV with units in the column names; ``extra`` adds per-pose columns (name -> (N,) array)."""
    cols = ["t_s", "x_m", "y_m", "z_m", "qx", "qy", "qz", "qw"]
    data = [traj.t, *traj.p.T, *traj.q.T]
    for k, v in (extra or {}).items():
        cols.append(k)
        data.append(np.asarray(v, float))
    np.savetxt(path, np.column_stack(data), delimiter=",", fmt="%.9f", header=",".join(cols), comments="")
    return Path(path)


def _geodetic(traj: Trajectory, origin: LocalTangentPlane) -> np.ndarray:
    lat, lon, h = origin.ned_to_geodetic(traj.p)
    return np.column_stack([lon, lat, h])


def write_geojson(path: str | Path, trajs: dict[str, Trajectory], origin: LocalTangentPlane) -> Path:
    """One LineString feature per trajectory (RFC 7946: longitude, latitude, height in metres)."""
    feats = []
    for name, tr in trajs.items():
        lla = _geodetic(tr, origin)
        feats.append({"type": "Feature", "properties": {"name": name, "t0_s": float(tr.t[0]),
                                                         "t1_s": float(tr.t[-1]), "poses": len(tr)},
                      "geometry": {"type": "LineString", "coordinates": np.round(lla, 9).tolist()}})
    Path(path).write_text(json.dumps({"type": "FeatureCollection", "features": feats}) + "\n")
    return Path(path)


def write_kml(path: str | Path, trajs: dict[str, Trajectory], origin: LocalTangentPlane) -> Path:
    """One LineString placemark per trajectory, absolute altitude (WGS84 height of the origin + up)."""
    colours = ["ff0000ff", "ffff0000", "ff00ff00", "ff00ffff"]
    marks = []
    for k, (name, tr) in enumerate(trajs.items()):
        lla = _geodetic(tr, origin)
        coords = " ".join(f"{lo:.9f},{la:.9f},{h:.3f}" for lo, la, h in lla)
        marks.append(f"<Placemark><name>{escape(name)}</name><Style><LineStyle><color>{colours[k % 4]}</color>"
                     f"<width>2</width></LineStyle></Style><LineString><altitudeMode>absolute</altitudeMode>"
                     f"<coordinates>{coords}</coordinates></LineString></Placemark>")
    Path(path).write_text('<?xml version="1.0" encoding="UTF-8"?>\n<kml xmlns="http://www.opengis.net/kml/2.2">'
                          f"<Document>{''.join(marks)}</Document></kml>\n")
    return Path(path)


def write_evaluation(ev, out_dir: str | Path, origin: LocalTangentPlane | None = None) -> list[Path]:
    """``eval.json`` (the summary), ``estimate_aligned.tum`` / ``.csv`` (with the per-pose APE), a plot
    (top view, APE over time, RPE), and GeoJSON / KML of both trajectories when ``origin`` is known."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = [out / "eval.json"]
    summary = ev.summary() | {"alignment_rotation": ev.alignment["rotation"].tolist(),
                              "alignment_translation_m": np.asarray(ev.alignment["translation"]).tolist()}
    files[0].write_text(json.dumps(summary, indent=2) + "\n")
    files.append(write_tum_file(out / "estimate_aligned.tum", ev.est, frame=ev.ref.frame or "reference"))
    files.append(write_csv(out / "estimate_aligned.csv", ev.est, {"ape_m": ev.ape}))
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5), constrained_layout=True)
    ax[0].plot(ev.ref.p[:, 1], ev.ref.p[:, 0], "k-", lw=1.2, label="reference")
    ax[0].plot(ev.est.p[:, 1], ev.est.p[:, 0], "C3-", lw=1.0, label="estimate" if ev.alignment["scale"] == 1.0 and not np.any(ev.alignment["translation"]) else "estimate (aligned)")
    ax[0].set(xlabel="y (east) [m]", ylabel="x (north) [m]", title="top view")
    ax[0].set_aspect("equal", adjustable="datalim")
    ax[0].legend(loc="best", fontsize=8)
    ax[1].plot(ev.ref.t, ev.ape, "C0-", lw=1.0)
    ax[1].axhline(float(np.sqrt(np.mean(ev.ape ** 2))), color="C1", ls="--", label="RMSE")
    ax[1].set(xlabel="time [s]", ylabel="APE [m]", title="absolute trajectory error")
    ax[1].legend(loc="best", fontsize=8)
    if ev.rpe.size:
        ax[2].hist(ev.rpe, bins=40, color="C2")
    ax[2].set(xlabel="RPE translation [m]", ylabel="pairs", title="relative pose error")
    fig.savefig(out / "eval.png", dpi=110)
    plt.close(fig)
    files.append(out / "eval.png")
    if origin is not None:
        trajs = {"reference": ev.ref, "estimate": ev.est}
        files.append(write_geojson(out / "trajectories.geojson", trajs, origin))
        files.append(write_kml(out / "trajectories.kml", trajs, origin))
    return files
