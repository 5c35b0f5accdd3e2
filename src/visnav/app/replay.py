"""``visnav replay``: run a navigator on a recorded flight and write the usual run directory.

The measurements of a ``Recording`` go to the navigator in delivery order; the recorded mission
requests (``commands.csv``) are replayed at their place in that order, and the estimate is asked at the
recorded times (a simulated recording) or at a fixed output rate (a recording without ``estimate``
rows). The navigators are those of the one registry (``app/navigators.py``), built from the recording's
scenario with its camera (``camera.yaml``) and, for WITAS, ``--map`` or the scenario's reference map.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
import numpy as np

from visnav.io.recording import STREAM_NAMES, STREAMS, Recording, RecordingError
from visnav.measurements import NavCommand, NavInit
from visnav.flightlog import FlightLog, register_stream
from visnav.analysis.outcome import replay_verdict
from visnav.analysis.check import camera_imu
from visnav.analysis.trajectory_eval import Trajectory, TrajectoryError, evaluate
from visnav.analysis.trajectory_export import write_tum_file
from visnav.app.navigators import make_navigator, spec, NAVIGATORS, stream_table
from visnav.io.json_values import jsonable
import tomllib
from visnav.scenarios.schema import apply_overrides, load_scenario, validate, to_toml
from visnav.world.maps import GeoImage
from visnav.analysis.replay_report import write_replay_report

register_stream("nav_request", method=("text", "", "a mission request replayed to the navigator (commands.csv): the "
                                             "NavCommand name, initialize, or an older recording's method"),
                args=("text", "JSON", "its arguments: {\"args\": [...], \"kwargs\": {...}}"))

@dataclass
class ReplayOptions:
    map_path: str | None = None  # reference map (GeoImage: PNG/JPEG + world file) where the navigator needs one
    output_rate_hz: float = 10.0  # estimate rate when the recording has no recorded estimate queries
    time_offset: str | float | None = None  # None: camera.yaml's; "auto": gyro/camera cross-correlation; seconds
    scenario_overrides: list[str] = field(default_factory=list)
    gps_until_s: float | None = None  # GPS samples describing later instants are withheld from the navigator
    gps_reference: bool = True  # without truth.csv, score against the GPS fixes


@dataclass
class ReplayResult:
    log: FlightLog
    metrics: dict
    scenario: object
    notes: list[str]
    frame: str = "NED world, body FRD"
    navigator: str = ""

    @property
    def verdict(self) -> str:
        """The summary's and the report's first line (``analysis/outcome.replay_verdict``)."""
        return replay_verdict(self.metrics, self.navigator)


def scenario_of(rec: Recording, default: str, overrides=()):
    """The recording's resolved scenario (``scenario.toml``), else the built-in ``default`` one."""


    if rec.scenario_toml is None:
        return load_scenario(default, list(overrides))
    try:
        data = tomllib.loads(rec.scenario_toml)
    except tomllib.TOMLDecodeError as exc:
        raise RecordingError(f"{rec.path / 'scenario.toml'}: not valid TOML ({exc})") from None
    return validate(apply_overrides(data, list(overrides)))


# ------------------------------------------------------------------------------------ navigators
def _navigator(name: str, rec: Recording, opts: ReplayOptions, recorder):
    """The registered navigator ``name`` (``app/navigators.py``) with the recording's camera and scenario."""
    s = spec(name)
    sc = scenario_of(rec, s.scenario, opts.scenario_overrides)
    kind = getattr(sc.mission, "type", "")
    if kind not in s.mission_types:  # another system's flight: the navigator's settings from its own scenario
        rec.notes.append(f"the recording was flown as {sc.run.name} (mission.type {kind}); the {name} navigator "
                         f"takes its settings from {s.scenario}")

        sc = load_scenario(s.scenario, list(opts.scenario_overrides))
    parts: dict = {}
    if rec.camera is not None:
        parts |= {"camera": rec.camera.camera, "mount": rec.camera.mount}
    elif name == "palace":  # no frames and no camera.yaml: the scenario's camera stands in for MPE's
        rec.notes.append("no camera.yaml and no frames: PALACE runs on GPS / inertial only")
    if name in ("witas", "geolocation"):
        if opts.map_path:
            try:
                parts["reference"] = GeoImage.load(opts.map_path)
            except (OSError, ValueError) as exc:
                raise RecordingError(f"{opts.map_path}: cannot load the reference map ({exc})") from None
        elif rec.scenario_toml is None:  # a simulated recording has its scenario: the closed loop's map
            raise RecordingError(f"{rec.path}: the {name} navigator needs a reference map: give --map MAP "
                                 "(PNG/JPEG + world file)")
    try:
        return make_navigator(name, sc, recorder, **parts), sc
    except ValueError as exc:
        raise RecordingError(str(exc)) from None


def offset_from_recording(rec: Recording, max_offset_s: float = 0.25):
    """Camera-to-IMU clock offset of a recording (``estimation/timesync.py``: frame rotations from feature
    tracks against the gyro, the camera-to-IMU rotation fitted with it); a ``CameraImuCalibration``."""
    rec.require(("imu", "frames"), "time-offset estimation (--time-offset auto)")
    cal, why = camera_imu(rec, max_offset_s=max_offset_s)
    if cal is None:
        raise RecordingError(f"{rec.path}: cannot estimate the time offset: {why}")
    return cal


# ------------------------------------------------------------------------------------ the replay
def _events(rec: Recording, out_rate: float):
    """Measurements and commands merged in delivery order: arrays (kind, a, b, time) with kind 0 =
    measurement (a = stream index, b = row), 1 = recorded command (b = row), 2 = estimate at ``time``."""
    tr, sq, si, ri = rec.delivery()
    kinds, a, b, times, seqs = [np.zeros(len(tr), int)], [si], [ri], [tr], [sq]
    c = rec.commands
    has_estimates = c is not None and np.any(c["method"] == "estimate")
    if c is not None and len(c["t_s"]):
        n = len(c["t_s"])
        kinds.append(np.ones(n, int))
        a.append(np.zeros(n, int))
        b.append(np.arange(n))
        times.append(c["t_s"])
        seqs.append(c["seq"] if "seq" in c else np.full(n, np.inf))
    if not has_estimates and len(tr):
        q = np.arange(np.ceil(tr[0] * out_rate), np.floor(tr[-1] * out_rate) + 1) / out_rate
        kinds.append(np.full(len(q), 2))
        a.append(np.zeros(len(q), int))
        b.append(np.arange(len(q)))
        times.append(q)
        seqs.append(np.full(len(q), np.inf))  # after the samples delivered at the same instant
    kinds, a, b, times, seqs = (np.concatenate(x) for x in (kinds, a, b, times, seqs))
    o = np.lexsort((np.arange(len(times)), seqs, times))
    return kinds[o], a[o], b[o], times[o]


def replay(rec: Recording, navigator: str, opts: ReplayOptions | None = None, progress=None) -> ReplayResult:
    """Run ``navigator`` on ``rec``; an error inside the replay stops it and keeps what it has
    (``metrics["error"]``)."""
    opts = opts or ReplayOptions()
    if navigator not in NAVIGATORS:
        raise RecordingError(f"unknown navigator {navigator!r}; replay knows {', '.join(sorted(NAVIGATORS))}")
    nspec = NAVIGATORS[navigator]
    rec.require(nspec.needs, navigator)
    rec.color = nspec.color_frames
    notes: list[str] = []
    metrics: dict = {}
    if opts.time_offset == "auto":
        est = offset_from_recording(rec)
        rec.time_offset_s = est.offset_s
        metrics |= {"time_offset_s": est.offset_s, "time_offset_sigma_s": est.offset_sigma_s}
        notes.append(f"time offset {est.offset_s * 1e3:.1f} +- {est.offset_sigma_s * 1e3:.1f} ms (frame rotations vs "
                     f"gyro, rate correlation {est.coarse.peak:.2f})")
    elif opts.time_offset is not None:
        rec.time_offset_s = float(opts.time_offset)
        metrics["time_offset_s"] = rec.time_offset_s

    log = FlightLog(schema=stream_table(nspec))  # the loop's units and frames (deck: the relative state)
    nav, sc = _navigator(navigator, rec, opts, log.record)
    kinds, a, b, times = _events(rec, opts.output_rate_hz)
    wall0 = time.perf_counter()
    cpu0 = time.process_time()
    counts, error = _feed(rec, nav, navigator, log, notes, (kinds, a, b, times), opts, progress)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    if nspec.finish is not None:
        nspec.finish(nav, log)
    reference = _log_reference(rec, log, opts)
    h = nav.health(float(times[-1]) if len(times) else 0.0)
    dur = float(times[-1] - times[0]) if len(times) else 0.0
    metrics |= {"frames_used": counts["frames"], "frames_dropped": int(rec.skipped.get("frames", 0)),
                "frames_in_recording": rec.count("frames"), "imu_samples": counts["imu"],
                "samples_rejected": int(getattr(h, "rejected_samples", 0))}
    est_valid = log.get("estimate").get("valid", []) if log.get("estimate") else []
    if len(est_valid):
        metrics["estimate_valid_share"] = float(np.mean(np.asarray(est_valid, bool)))
    if opts.gps_until_s is not None:
        metrics["gps_withheld"] = counts["gps_withheld"]
    if counts["fixes"]:  # a navigator with a ground-station half (CONDOR): its fixes over the link
        metrics |= {"link_fixes": counts["fixes"], "link_fixes_delivered": counts["fixes_delivered"],
                    "link_fixes_missing": counts["fixes_missing"]}
        if counts["fixes_missing"]:
            notes.append(f"link.csv: {counts['fixes_missing']} delivered fix(es) the replayed navigator did not make")
    if hasattr(nav, "replay_metrics"):  # a navigator's own figures (vo: pairs_registered_share)
        metrics |= nav.replay_metrics()
    if reference:
        metrics["reference"] = reference
        metrics |= _accuracy(log, True)
        if opts.gps_until_s is not None:
            metrics |= denied_metrics(log, opts.gps_until_s)
    metrics |= {"replay_wall_s": wall, "replay_cpu_s": cpu,
                "replay_real_time_factor": dur / wall if wall > 0 else float("nan"),
                "replay_real_time_factor_cpu": dur / cpu if cpu > 0 else float("nan"), "flight_duration_s": dur}
    if counts.get("interrupted"):
        metrics["interrupted"] = True
        notes.append("interrupted (Ctrl-C): the run directory holds the replay up to there")
    if error:
        metrics["error"] = error
        notes.append(f"the replay stopped early: {error} (what it had is kept)")
    notes += rec.notes
    if rec.skipped:
        notes.append(f"skipped during the replay: {', '.join(f'{v} {k}' for k, v in rec.skipped.items())}")
    return ReplayResult(log=log, metrics=metrics, scenario=sc, notes=notes, frame=nspec.frame, navigator=navigator)


def _feed(rec, nav, navigator, log, notes, events, opts, progress) -> tuple[dict, str | None]:
    """The replay loop: samples to ``update``, recorded requests to their methods, estimates to the log."""
    kinds, a, b, times = events
    c = rec.commands
    counts = {"frames": 0, "imu": 0, "gps_withheld": 0, "fixes": 0, "fixes_delivered": 0, "fixes_missing": 0}
    by_index = {STREAM_NAMES.index(s): s for s in rec.streams}
    cut = opts.gps_until_s if opts.gps_until_s is not None else np.inf
    row = NAVIGATORS[navigator].estimate_row or _estimate_row
    pending: list = []  # the estimate query not yet logged: (t, fields); a later one at the same t replaces it
    # (the first stays where the navigator's loop logs the step's own estimate: NavigatorSpec.log_first_estimate)
    uplink = getattr(nav, "pop_uplink", None)  # a ground-station half's fixes (CONDOR): back through link.csv
    fixes: dict[float, object] = {}
    via_link = "link" in rec.streams
    unused: set[str] = set()
    k, t = 0, float("nan")

    def flush():
        if pending:
            log.record("estimate", pending[0], **pending[1])
            pending.clear()

    def deliver(m):
        nav.update(m)
        if uplink is None:
            return
        for fix in uplink():
            counts["fixes"] += 1
            if via_link:
                fixes[float(fix.t)] = fix
            else:  # no link log: the fix reaches the navigator's on-board half at once
                counts["fixes_delivered"] += 1
                nav.update(fix)

    try:
        for k in range(len(kinds)):
            t = float(times[k])
            if kinds[k] == 0:
                name = by_index[a[k]]
                if name == "link":
                    t_fix = float(rec.streams["link"]["t_s"][b[k]]) + rec.time_offset_s
                    for lost in [x for x in fixes if x < t_fix - 1e-9]:  # link.csv is in fix order: lost on the link
                        del fixes[lost]
                    key = min(fixes, key=lambda x: abs(x - t_fix), default=None)
                    if key is None or abs(key - t_fix) > 1e-9:
                        counts["fixes_missing"] += 1
                        continue
                    counts["fixes_delivered"] += 1
                    nav.update(fixes.pop(key))
                    continue
                m = rec.sample(name, int(b[k]))
                if m is None:
                    continue
                if name == "gps" and m.t > cut:
                    counts["gps_withheld"] += 1
                    continue
                if name in ("frames", "imu"):
                    counts[name] += 1
                if name in unused:
                    continue
                try:
                    deliver(m)
                except TypeError:  # a stream this navigator does not take (baro to the deck's): left out, said once
                    if name in NAVIGATORS[navigator].needs:
                        raise
                    unused.add(name)
                    notes.append(f"{STREAMS[name].file}: the {navigator} navigator does not take {name} "
                                 "samples; left out")
            elif kinds[k] == 2 or c["method"][b[k]] == "estimate":
                t = t if kinds[k] == 2 else _query_t(c, b[k], t)
                if pending and pending[0] != t:
                    flush()
                if not (pending and NAVIGATORS[navigator].log_first_estimate):  # (the step's own: CONDOR)
                    pending[:] = [t, row(nav.estimate(t))]
            elif c["method"][b[k]] == "health":
                t = _query_t(c, b[k], t)
                h = nav.health(t)
                log.record("status", t, source=h.source, coherence=h.coherence, tracking=h.tracking,
                           mpe_rate_hz=h.mpe_rate_hz, laser_ok=h.laser_ok)
            else:
                meth = str(c["method"][b[k]])
                args = json.loads(c["args"][b[k]]) if "args" in c and c["args"][b[k]] else {}
                if meth in ("command", "initialize"):  # a NavCommand / NavInit: rebuilt from its fields
                    kw = args.get("kwargs", {})
                    if meth == "command":
                        nav.command(NavCommand(kw.get("t", t), kw["name"], kw.get("args", {})))
                        meth = kw["name"]
                    else:
                        arr = lambda x: None if x is None else np.asarray(x, float)  # noqa: E731
                        nav.initialize(NavInit(kw.get("t", t), kw.get("source", "recorded"),
                                               *(arr(kw.get(f)) for f in ("position", "velocity", "attitude", "state",
                                                                          "covariance"))))
                    log.record("nav_request", t, method=meth, args=json.dumps(args))
                    continue
                fn = getattr(nav, meth, None)
                if fn is None:
                    notes.append(f"commands.csv: {meth!r} is not a {navigator} navigator request; skipped")
                    continue
                fn(*args.get("args", []), **args.get("kwargs", {}))
                log.record("nav_request", t, method=meth, args=json.dumps(args))
            if progress is not None and k % 2000 == 0:
                progress(k, len(kinds))
    except KeyboardInterrupt:  # Ctrl-C: keep what the replay has
        counts["interrupted"] = True
    except Exception as exc:  # keep what the replay has
        flush()
        return counts, f"{type(exc).__name__} at t={t:.3f} s (event {k} of {len(kinds)}): {exc}"
    flush()
    return counts, None


def _query_t(c, row: int, t: float) -> float:
    """The instant an ``estimate`` / ``health`` row asked for: its ``t`` argument where it has one (the bridge's
    log: the estimate at a frame's exposure, asked after later samples arrived), else the row's time."""
    if "args" in c and c["args"][row]:
        kw = json.loads(c["args"][row]).get("kwargs", {})
        if "t" in kw:
            return float(kw["t"])
    return t


def _estimate_row(e) -> dict:
    """A ``NavEstimate`` as the ``estimate`` stream logs it."""
    return {"position": e.position, "velocity": e.velocity, "euler": e.attitude, "source": e.source, "valid": e.valid}


def _log_reference(rec: Recording, log: FlightLog, opts: ReplayOptions) -> str | None:
    """truth.csv into the log's ``truth`` stream; without one, the GPS fixes (all of them, also those
    withheld from the navigator by ``gps_until_s``) serve as the reference. Returns its name."""
    tr, name = rec.truth, "truth.csv"
    if tr is None and "gps" in rec.streams and opts.gps_reference:
        tr, name = rec.streams["gps"], "gps.csv"
    if tr is None:
        return None
    n = len(tr["t_s"])
    col = lambda keys, fill: np.column_stack([tr[k] if k in tr else np.full(n, fill) for k in keys])  # noqa: E731
    p, v, e = col(("n_m", "e_m", "d_m"), np.nan), col(("vn_mps", "ve_mps", "vd_mps"), np.nan), \
        col(("roll_rad", "pitch_rad", "yaw_rad"), 0.0)
    for i, t in enumerate(tr["t_s"]):
        log.record("truth", t, position=p[i], velocity=v[i], euler=e[i])
    return name


def trajectories(log: FlightLog, frame: str = "NED world, body FRD"):
    """(valid estimates, truth) as ``Trajectory`` (truth None when the recording has none)."""
    from scipy.spatial.transform import Rotation

    def traj(s, name, mask=None):
        e = np.asarray(s["euler"], float).reshape(-1, 3)
        p = np.asarray(s["position"], float).reshape(-1, 3)
        t = np.asarray(s["t"], float)
        if mask is not None:
            t, p, e = t[mask], p[mask], e[mask]
        q = Rotation.from_euler("ZYX", e[:, ::-1]).as_quat() if len(t) else np.zeros((0, 4))
        return Trajectory(t, p, q, name, frame)

    es = log.get("estimate")
    valid = np.asarray(es["valid"], bool) & np.all(np.isfinite(np.asarray(es["position"], float)), axis=1) \
        if es else None
    est = traj(es, "estimate", valid) if es else None
    tr = log.get("truth")
    return est, (traj(tr, "truth") if tr else None)


def _accuracy(log: FlightLog, has_truth: bool) -> dict:
    est, ref = trajectories(log)
    if not has_truth or est is None or ref is None or len(est) == 0:
        return {}
    try:
        s = evaluate(ref, est, alignment="none").summary()  # evo's defaults, as `visnav eval RUN` and evo_ape score the folder
    except TrajectoryError as exc:
        return {"ate_note": str(exc)}
    return {"ate_rmse_m": s["ate_rmse_m"], "ate_max_m": s["ate_max_m"], "rpe_rmse_m": s["rpe_rmse_m"]}


def denied_metrics(log: FlightLog, t_cut: float) -> dict:
    """The GPS-denied part of a replay (after ``t_cut``) against the reference, horizontally (a GPS altitude is
    too noisy to score a height): ``final_error_m`` at the last reference sample, ``final_error_pct_of_distance``
    = that over the reference's path length since ``t_cut`` in %, ``ate_rmse_denied_m`` over the denied part."""
    est, ref = trajectories(log)
    if est is None or ref is None or len(est) < 2:
        return {}
    keep = (ref.t > t_cut) & (ref.t >= est.t[0]) & (ref.t <= est.t[-1])
    if not keep.any():
        return {"denied_note": f"no reference sample after {t_cut:g} s within the estimate"}
    t = ref.t[keep]
    p_ref = ref.p[keep, :2]
    p_est = np.column_stack([np.interp(t, est.t, est.p[:, j]) for j in range(2)])
    start = np.array([np.interp(t_cut, ref.t, ref.p[:, j]) for j in range(2)])
    dist = float(np.linalg.norm(np.diff(np.vstack([start, p_ref]), axis=0), axis=1).sum())
    err = np.linalg.norm(p_est - p_ref, axis=1)
    return {"final_error_m": float(err[-1]), "distance_denied_m": dist,
            "final_error_pct_of_distance": float(100 * err[-1] / dist) if dist > 0 else float("nan"),
            "ate_rmse_denied_m": float(np.sqrt(np.mean(err ** 2))), "denied_s": float(t[-1] - t_cut)}


def write_replay(result: ReplayResult, out_dir: Path, report: bool = True, title: str = "visnav replay") -> Path:
    """log.h5, scenario.toml, estimate.tum (valid estimates only; the header names the frame), truth.tum,
    metrics.json, report.html."""

    result.log.to_hdf5(out_dir / "log.h5", attrs={"replay": 1})
    (out_dir / "scenario.toml").write_text(to_toml(result.scenario))
    (out_dir / "metrics.json").write_text(json.dumps(jsonable(result.metrics), indent=2) + "\n")
    est, ref = trajectories(result.log, result.frame)
    if est is not None:
        write_tum_file(out_dir / "estimate.tum", est, result.frame)
    if ref is not None:
        write_tum_file(out_dir / "truth.tum", ref, result.frame)
    if report:
        write_replay_report(result, out_dir / "report.html", title, result.verdict)
    return out_dir
