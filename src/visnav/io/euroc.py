"""The EuRoC / ASL dataset layout read into a ``Recording`` (Burri et al. 2016, "The EuRoC micro aerial
vehicle datasets", IJRR; the ASL folder format of its ``mav0/``)::

    ROOT/mav0/cam0/data.csv        #timestamp [ns],filename      cam0/data/<ns>.png
    ROOT/mav0/cam0/sensor.yaml     T_BS (4x4, row-major 'data'), intrinsics [fu, fv, cu, cv], resolution
                                   [w, h], distortion_model radial-tangential (k1, k2, p1, p2)
    ROOT/mav0/imu0/data.csv        #timestamp [ns], w_RS_S_x..z [rad/s], a_RS_S_x..z [m/s^2]
    ROOT/mav0/imu0/sensor.yaml     T_BS of the IMU (identity in EuRoC: the body frame B is the IMU's)
    ROOT/mav0/state_groundtruth_estimate0/data.csv   #timestamp, p_RS_R_x..z [m], q_RS_w, q_RS_x..z, ...
    or a TUM file next to mav0 (``*.tum``: t[s] x y z qx qy qz qw, the pose of the body B in the world R)

Timestamps are integer nanoseconds (read as int64: a float64 holds them to only 256 ns); every stream
is put on seconds from the first IMU sample. ``T_BS`` maps sensor coordinates to body coordinates
(p_B = T_BS p_S).

Axes. The EuRoC body frame B is the IMU's own (ADIS16448: x up, y right, z forward on the V1 MAV,
the camera looking along +z). visnav's recordings are in body FRD and NED, so the reader turns B into
an FRD body whose *forward is the body axis closest to cam0's optical axis* and whose *down is the
axis closest to gravity at rest* (the mean specific force of the first ``_REST_S`` seconds points up),
right completing the triad: ``R_frd_B``, a signed permutation (a proper rotation). The IMU samples,
the camera mount (``R_cam_to_body = R_frd_B R_BS``) and the ground truth attitude are turned with it,
and the recording's notes say so. The ground truth world R (z up, x and y arbitrary: Vicon) is taken
as ENU (north = y, east = x, down = -z): roll and pitch are exact, yaw is relative to the Vicon x axis.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.io.recording import CameraInfo, Recording, RecordingError
from visnav.geometry.rotations import dcm_to_euler

_REST_S = 0.5
_T_NED_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def is_euroc(path: str | Path) -> bool:
    """A folder that holds ``mav0/imu0/data.csv`` (or is ``mav0`` itself)."""
    p = Path(path)
    return p.is_dir() and ((p / "mav0" / "imu0" / "data.csv").is_file() or (p / "imu0" / "data.csv").is_file())


def _csv_ns(path: Path, min_cols: int) -> tuple[np.ndarray, np.ndarray]:
    """An ASL ``data.csv``: (int64 ns stamps, the other columns as strings (N, k))."""
    if not path.is_file():
        raise RecordingError(f"{path}: missing")
    rows = []
    with open(path) as fh:
        for ln, line in enumerate(fh, 1):
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            parts = [c.strip() for c in s.split(",")]
            if len(parts) < min_cols:
                raise RecordingError(f"{path}: line {ln}: {len(parts)} values, at least {min_cols} needed")
            rows.append(parts)
    if not rows:
        raise RecordingError(f"{path}: no data rows")
    try:
        t = np.array([int(r[0]) for r in rows], dtype=np.int64)
    except ValueError:
        bad = next(i for i, r in enumerate(rows) if not r[0].lstrip("-").isdigit())
        raise RecordingError(f"{path}: row {bad + 1}: timestamp {rows[bad][0]!r} is not integer nanoseconds") from None
    return t, np.array([r[1:] for r in rows], dtype=object)


def _floats(path: Path, cols: np.ndarray) -> np.ndarray:
    try:
        return np.array(cols.tolist(), dtype=float)
    except ValueError as exc:
        raise RecordingError(f"{path}: {exc}") from None


def _sensor_yaml(path: Path) -> dict:
    import yaml

    if not path.is_file():
        return {}
    text = path.read_text()
    text = "\n".join(ln for ln in text.splitlines() if not ln.startswith("%YAML"))  # OpenCV's directive
    try:
        doc = yaml.safe_load(text) or {}
    except yaml.YAMLError as exc:
        raise RecordingError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, dict):
        raise RecordingError(f"{path}: expected a mapping of keys")
    return doc


def _T_BS(path: Path, doc: dict) -> np.ndarray:
    """The 4x4 sensor-to-body transform (row-major ``data``); identity when absent."""
    T = doc.get("T_BS")
    if T is None:
        return np.eye(4)
    try:
        data = np.asarray(T["data"] if isinstance(T, dict) else T, float)
        rows, cols = (int(T.get("rows", 4)), int(T.get("cols", 4))) if isinstance(T, dict) else (4, 4)
        M = data.reshape(rows, cols)
    except (KeyError, TypeError, ValueError) as exc:
        raise RecordingError(f"{path}: T_BS is not a 4x4 matrix ({exc})") from None
    if M.shape != (4, 4):
        raise RecordingError(f"{path}: T_BS is {M.shape[0]}x{M.shape[1]}, expected 4x4")
    R = M[:3, :3]
    if abs(np.linalg.det(R) - 1) > 1e-3 or np.abs(R @ R.T - np.eye(3)).max() > 1e-3:
        raise RecordingError(f"{path}: the rotation part of T_BS is not a rotation (det {np.linalg.det(R):.4f})")
    return M


def _frd_from_body(f_rest: np.ndarray, cam_axis_B: np.ndarray | None) -> np.ndarray:
    """R_frd_B (module docstring): down = -(mean specific force at rest), forward = the camera's axis."""
    down = np.zeros(3)
    i_d = int(np.argmax(np.abs(f_rest)))
    down[i_d] = -np.sign(f_rest[i_d])
    fwd = np.zeros(3)
    if cam_axis_B is not None:
        c = np.abs(cam_axis_B).copy()
        c[i_d] = -1
        i_f = int(np.argmax(c))
        fwd[i_f] = np.sign(cam_axis_B[i_f])
    else:  # no camera: the first axis that is not down
        i_f = 0 if i_d != 0 else 1
        fwd[i_f] = 1.0
    return np.vstack([fwd, np.cross(down, fwd), down])


def _read_tum(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A TUM file: (int64 ns, positions (N,3), quaternions xyzw (N,4)); stamps parsed exactly."""
    ns, rest = [], []
    for ln, line in enumerate(path.read_text().splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.split()
        if len(parts) != 8:
            raise RecordingError(f"{path}: line {ln}: {len(parts)} values, TUM has 8 (t x y z qx qy qz qw)")
        sec, _, frac = parts[0].partition(".")
        try:
            ns.append(int(sec) * 10**9 + int((frac + "000000000")[:9]))
            rest.append([float(x) for x in parts[1:]])
        except ValueError:
            raise RecordingError(f"{path}: line {ln}: not numbers") from None
    if not ns:
        raise RecordingError(f"{path}: no poses")
    a = np.array(rest)
    return np.array(ns, np.int64), a[:, :3], a[:, 3:]


def read_euroc(path: str | Path) -> Recording:
    """An EuRoC / ASL folder (``ROOT`` holding ``mav0/``, or ``mav0`` itself) as a ``Recording``."""
    from scipy.spatial.transform import Rotation


    root = Path(path)
    mav = root / "mav0" if (root / "mav0").is_dir() else root
    notes: list[str] = []
    imu_csv = mav / "imu0" / "data.csv"
    t_imu, cols = _csv_ns(imu_csv, 7)
    v = _floats(imu_csv, cols[:, :6])
    o = np.argsort(t_imu, kind="stable")
    if np.any(np.diff(o) < 0):
        notes.append(f"{imu_csv}: samples re-sorted by time")
    t_imu, v = t_imu[o], v[o]
    R_BI = _T_BS(mav / "imu0" / "sensor.yaml", _sensor_yaml(mav / "imu0" / "sensor.yaml"))[:3, :3]
    gyro_B, acc_B = v[:, :3] @ R_BI.T, v[:, 3:6] @ R_BI.T
    t0 = int(t_imu[0])
    sec = lambda ns: (np.asarray(ns, np.int64) - t0) * 1e-9  # noqa: E731

    cam_dir = mav / "cam0"
    camera = None
    R_BC = None
    frames = None
    if (cam_dir / "data.csv").is_file():
        ydoc = _sensor_yaml(cam_dir / "sensor.yaml")
        if not ydoc:
            raise RecordingError(f"{cam_dir / 'sensor.yaml'}: missing (cam0's intrinsics and T_BS)")
        R_BC = _T_BS(cam_dir / "sensor.yaml", ydoc)[:3, :3]
        model = str(ydoc.get("distortion_model", "radial-tangential"))
        if ydoc.get("camera_model", "pinhole") != "pinhole" or model not in ("radial-tangential", "radtan", "none"):
            raise RecordingError(f"{cam_dir / 'sensor.yaml'}: camera model {ydoc.get('camera_model')!r} / distortion "
                                 f"{model!r}; only pinhole with radial-tangential distortion is read")
        try:
            fu, fv, cu, cv = (float(x) for x in ydoc["intrinsics"])
            w, h = (int(x) for x in ydoc["resolution"])
            dist = [float(x) for x in ydoc.get("distortion_coefficients", [])][:4]
        except (KeyError, TypeError, ValueError) as exc:
            raise RecordingError(f"{cam_dir / 'sensor.yaml'}: intrinsics [fu, fv, cu, cv] and resolution [w, h] "
                                 f"needed ({exc})") from None
        camera = PinholeCamera(w, h, fu, fv, cu, cv, tuple(dist + [0.0] * (8 - len(dist))))
        t_cam, fc = _csv_ns(cam_dir / "data.csv", 2)
        rel = (cam_dir / "data").relative_to(root)
        files = np.array([str(rel / str(f)) for f in fc[:, 0]])
        missing = [f for f in files if not (root / f).is_file()]
        if missing:
            raise RecordingError(f"{root / missing[0]}: frame file missing (listed in {cam_dir / 'data.csv'}; "
                                 f"{len(missing)} of {len(files)} missing)")
        o = np.argsort(t_cam, kind="stable")
        frames = {"t_s": sec(t_cam[o]), "file": files[o], "index": np.arange(len(o), dtype=float)}

    rest = t_imu <= t_imu[0] + int(_REST_S * 1e9)
    R_fB = _frd_from_body(acc_B[rest].mean(axis=0), R_BC[:, 2] if R_BC is not None else None)
    notes.append("EuRoC body axes (the IMU's) turned into FRD: forward = body "
                 + _axis_name(R_fB[0]) + " (cam0's optical axis), down = body " + _axis_name(R_fB[2])
                 + " (against gravity at rest)")
    g, a = gyro_B @ R_fB.T, acc_B @ R_fB.T
    streams = {"imu": {"t_s": sec(t_imu), **{f"a{ax}_mps2": a[:, i] for i, ax in enumerate("xyz")},
                       **{f"g{ax}_radps": g[:, i] for i, ax in enumerate("xyz")}}}
    cam_info = None
    if frames is not None:
        streams["frames"] = frames
        cam_info = CameraInfo(camera, FixedMount(R_fB @ R_BC, np.zeros(3)), 0.0)

    truth = None
    gt_csv = mav / "state_groundtruth_estimate0" / "data.csv"
    tums = sorted(p for p in {*root.glob("*.tum"), *mav.glob("*.tum")} if p.is_file())
    if gt_csv.is_file():
        t_gt, gc = _csv_ns(gt_csv, 8)
        gv = _floats(gt_csv, gc[:, :7])
        pos, q_xyzw = gv[:, :3], gv[:, [4, 5, 6, 3]]  # q_RS_w first in the ASL file
        src = gt_csv
    elif tums:
        src = next((p for p in tums if "body" in p.name), tums[0])
        t_gt, pos, q_xyzw = _read_tum(src)
    else:
        t_gt = None
    if t_gt is not None:
        o = np.argsort(t_gt, kind="stable")
        C_RB = Rotation.from_quat(q_xyzw[o]).as_matrix()
        C_nb = _T_NED_ENU @ C_RB @ R_fB.T  # FRD body -> NED world (the Vicon world taken as ENU)
        e = dcm_to_euler(C_nb)
        p = pos[o] @ _T_NED_ENU.T
        truth = {"t_s": sec(t_gt[o]), "n_m": p[:, 0], "e_m": p[:, 1], "d_m": p[:, 2],
                 "roll_rad": e[:, 0], "pitch_rad": e[:, 1], "yaw_rad": e[:, 2]}
        notes.append(f"ground truth from {src.name}: world z up taken as ENU (yaw relative to its x axis)")
    rec = Recording(root, cam_info, streams, truth=truth)
    rec.notes += notes
    return rec


def _axis_name(row: np.ndarray) -> str:
    i = int(np.argmax(np.abs(row)))
    return ("+" if row[i] > 0 else "-") + "xyz"[i]
