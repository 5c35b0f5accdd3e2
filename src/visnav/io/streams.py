"""Conversions of raw sensor columns into the recording's stream columns (folder CSVs and logs alike).

* GPS in latitude / longitude / altitude -> local NED about the first fix (``geometry/frames.py``),
  velocity from the receiver when given, else central differences of the positions;
* magnetometer field vectors (body FRD, any unit) -> tilt-compensated heading with the recording's
  attitude (the vectorised form of ``estimation/eskf.heading_from_mag``), declination added.
"""

from __future__ import annotations

import numpy as np
from visnav.geometry.frames import LocalTangentPlane


def headings_from_mag(mag: np.ndarray, roll, pitch, declination: float = 0.0) -> np.ndarray:
    """Tilt-compensated heading [rad] of body-frame field vectors, vectorised ``eskf.heading_from_mag``."""
    m = np.asarray(mag, float).reshape(-1, 3)
    cr, sr, cp, sp = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    mx = m[:, 0] * cp + m[:, 1] * sr * sp + m[:, 2] * cr * sp
    my = m[:, 1] * cr - m[:, 2] * sr
    return np.angle(np.exp(1j * (np.arctan2(-my, mx) + declination)))


def heading_stream(t, mag, att: dict, declination: float = 0.0) -> dict:
    """``magnetometer`` columns from field vectors at ``t``, roll and pitch interpolated from ``att``."""
    roll = np.interp(t, att["t_s"], att["roll_rad"])
    pitch = np.interp(t, att["t_s"], att["pitch_rad"])
    return {"t_s": np.asarray(t, float), "heading_rad": headings_from_mag(mag, roll, pitch, declination)}


def gps_stream(t, lat, lon, alt, vel=None, origin=None) -> dict:
    """``gps`` columns (NED about ``origin`` = (lat, lon, alt), default the first fix)."""

    t = np.asarray(t, float)
    o = origin if origin is not None else (lat[0], lon[0], alt[0])
    ned = LocalTangentPlane(*o).geodetic_to_ned(lat, lon, alt)
    if vel is None:  # no velocity from the receiver: central differences of the positions
        vel = np.column_stack([np.gradient(ned[:, j], t) for j in range(3)]) if len(t) > 1 else np.zeros((len(t), 3))
    vel = np.asarray(vel, float)
    return {"t_s": t, "n_m": ned[:, 0], "e_m": ned[:, 1], "d_m": ned[:, 2], "vn_mps": vel[:, 0], "ve_mps": vel[:, 1],
            "vd_mps": vel[:, 2]}


def sorted_stream(stream: dict, notes: list, what: str) -> dict:
    """Sort by t_s (and drop non-finite stamps): logs are repaired with a note, not refused."""
    t = stream["t_s"]
    keep = np.isfinite(t)
    if not keep.all():
        notes.append(f"{what}: {int((~keep).sum())} samples without a valid time dropped")
    o = np.argsort(np.where(keep, t, np.inf), kind="stable")[: int(keep.sum())]
    if np.any(np.diff(o) < 0):
        notes.append(f"{what}: samples re-sorted by time")
    return {k: v[o] for k, v in stream.items()}


def read_summary(name: str, dur: float, size: int, at: int | None, cut: bool, parts: list[str]) -> str:
    """The one line a log reader gives: what was read, to the end or to the damage."""
    where = (f"to the end ({size} bytes)" if at is None else
             f"cut at byte {at} of {size} (the file ends inside a message)" if cut else
             f"damaged at byte {at} of {size}, read on where messages resume")
    return f"{name}: read {dur:.1f} s; {where}; " + ", ".join(parts)


def mag_field_stream(t, mag_gauss) -> dict:
    m = np.asarray(mag_gauss, float)
    return {"t_s": np.asarray(t, float), "mx_ga": m[:, 0], "my_ga": m[:, 1], "mz_ga": m[:, 2]}


def flow_stream(t, flow, dist=None) -> dict:
    """``optical_flow`` columns: flow x, y and body rates x, y [rad/s], quality (0..255), distance [m]."""
    f = np.asarray(flow, float)
    out = {"t_s": np.asarray(t, float), "flow_x_radps": f[:, 0], "flow_y_radps": f[:, 1], "body_x_radps": f[:, 2],
           "body_y_radps": f[:, 3], "quality": f[:, 4]}
    return out | ({"distance_m": np.asarray(dist, float)} if dist is not None else {})


def camera_stream(t, seq, lla=None) -> dict:
    out = {"t_s": np.asarray(t, float), "seq": np.asarray(seq, float)}
    if lla is not None:
        out |= {"lat_deg": lla[:, 0], "lon_deg": lla[:, 1], "alt_m": lla[:, 2]}
    return out
