"""Margins campaigns: closed-loop chirps flown in the simulator (seed 000 Tables 5.1/5.2).

Each sweep is a hover with a chirp at one cyclic actuator (``palace-sweep``); from it come the
broken-loop margins (``frequency``) and the sensor delays (``delay_id``). ``margins_campaign``
flies the rows of Table 5.1 (GPS, MPE with late attitude) and, with compensation, the rows of
Table 5.2 (MPE with the identified delays applied).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from visnav.analysis.delay_id import CombinedDelay, combine_delays, identify_imu_delay, identify_laser_delays
from visnav.analysis.frequency import AXIS_INDEX, broken_loop_response, margins_from_frd
from visnav.app.loop import Simulation
from visnav.scenarios.schema import load_scenario, ScenarioError, builtin_names
import multiprocessing
from concurrent.futures import ProcessPoolExecutor


@dataclass(frozen=True)
class SweepSettings:
    """The chirp injected at the actuator (YACS units, Hz, s) and the analysis settings.

    The amplitude shrinks below ``amplitude_ref_altitude_m`` (to ``min_amplitude_fraction``): close
    to the ground the same tilt moves the tracked point faster and the tracker loses it. Above it
    the amplitude grows with height (up to ``max_amplitude_fraction``): the MPE noise grows with
    the range while the response to a given tilt does not, so the same chirp loses coherence. Phase
    crossovers where the coherence stays below ``min_coherence`` (MPE noise grows with height) are
    read from points down to ``gm_min_coherence`` and flagged."""

    amplitude: float = 40.0
    f0_hz: float = 0.08
    f1_hz: float = 2.5
    duration_s: float = 80.0
    start_s: float = 3.0
    amplitude_ref_altitude_m: float = 12.0
    min_amplitude_fraction: float = 0.75
    max_amplitude_fraction: float = 1.0
    delay_band_hz: tuple[float, float] = (0.5, 2.5)
    min_coherence: float = 0.6
    gm_min_coherence: float = 0.3

    def amplitude_at(self, altitude_m: float) -> float:
        scale = min(self.max_amplitude_fraction,
                    max(self.min_amplitude_fraction, altitude_m / self.amplitude_ref_altitude_m))
        return self.amplitude * scale

    def overrides(self, altitude_m: float) -> list[str]:
        return [f"mission.sweep_amplitude={self.amplitude_at(altitude_m)}", f"mission.sweep_f0_hz={self.f0_hz}",
                f"mission.sweep_f1_hz={self.f1_hz}", f"mission.sweep_duration_s={self.duration_s}",
                f"mission.sweep_start_s={self.start_s}", f"mission.hold_s={self.start_s + self.duration_s + 1.0}",
                f"run.duration_s={self.start_s + self.duration_s + 30.0}"]


def sweep_run(altitude_m: float, axis: str, source: str = "mpe", imu_delay_s: float = 0.0,
              attitude_delay_s: float = 0.0, seed: int = 1, sweep: SweepSettings = SweepSettings(),
              scenario: str = "palace-sweep", overrides: tuple[str, ...] = (), laser_delay_s: float = 0.0,
              laser_compensation_s: float = 0.0) -> dict:
    """One hover with a chirp at the ``axis`` actuator: its margins (NaN when the sweep did not
    complete), the IMU delay behind the camera identified from the same sweep (roll for lateral,
    pitch for longitudinal; ``delay_s``), on longitudinal sweeps the laser's delay behind the
    camera (``laser_delay_s``, Fig. 5.2) and the IMU's behind the laser (``imu_vs_laser_s``, Fig.
    5.4), and notes (track lost, sweep cut short, point near the image edge). ``imu_delay_s`` and
    ``laser_delay_s`` are the simulated (unknown) sensor delays; ``attitude_delay_s`` and
    ``laser_compensation_s`` the navigator's compensation (``navigation.mpe.*``)."""

    if axis not in AXIS_INDEX:
        raise ValueError(f"axis must be one of {sorted(AXIS_INDEX)}, got {axis!r}")
    ov = [*overrides, f"mission.altitude_m={altitude_m}", f'mission.source="{source}"',
          f'mission.sweep_axis="{axis}"', f"sensors.imu.delay_s={imu_delay_s}",
          f"navigation.mpe.attitude_delay_s={attitude_delay_s}", f"sensors.laser.delay_s={laser_delay_s}",
          f"navigation.mpe.laser_delay_s={laser_compensation_s}", *sweep.overrides(altitude_m)]
    sc = load_scenario(scenario, ov, seed=seed)
    res = Simulation(sc).run()
    log, notes = res.log, []
    out = dict(pm_deg=math.nan, w_gc=math.nan, gm_db=math.nan, w_pc=math.nan, delay_s=math.nan,
               delay_std_s=math.nan, laser_delay_s=math.nan, laser_delay_std_s=math.nan,
               imu_vs_laser_s=math.nan, frf=None, notes=notes)
    if res.error:
        notes.append(res.error)
    modes = list(log.get("mode").get("mode", [])) if "mode" in log else []
    if "lost" in modes:
        notes.append(f"track lost at {log.get('mode')['t'][modes.index('lost')]:.1f} s")
    a = log.get("actuator") if "actuator" in log else {}
    if not a or a["t"][-1] - a["t"][0] < 0.95 * sweep.duration_s:
        notes.append("sweep incomplete: loop unstable or track lost")
        return out
    cam = sc.sensors.camera
    tr = log.get("tracker")
    sel = (tr["t"] >= a["t"][0]) & (tr["t"] <= a["t"][-1])
    x, y = tr["x"][sel], tr["y"][sel]
    edge = min(x.min(), cam.width - x.max(), y.min(), cam.height - y.max())
    if edge < 40:
        notes.append(f"tracked point within {edge:.0f} px of the image edge")
    fr = broken_loop_response(log, axis, sweep.f0_hz, 0.9 * sweep.f1_hz)  # the chirp's ends are weak
    out["frf"] = dict(w=fr.w_rad_s, H=fr.H, coherence=fr.coherence)
    out.update(_margins(fr.w_rad_s, fr.H, fr.coherence, sweep, notes))
    lo, hi = sweep.delay_band_hz
    try:
        d = identify_imu_delay(log, cam.focal_px, (cam.width / 2, cam.height / 2), cam.depression_deg,
                               "roll" if axis == "lateral" else "pitch", lo, min(hi, sweep.f1_hz))
        out.update(delay_s=d.delay_s, delay_std_s=d.std_s)
    except ValueError as exc:
        notes.append(f"delay: {exc}")
    if axis == "longitudinal":  # the laser sees pitch (its range along the optical axis), not roll
        try:
            ld = identify_laser_delays(log, cam.focal_px, (cam.width / 2, cam.height / 2), cam.depression_deg,
                                       lo, min(hi, sweep.f1_hz))
            out.update(laser_delay_s=ld["laser_vs_camera"].delay_s, laser_delay_std_s=ld["laser_vs_camera"].std_s,
                       imu_vs_laser_s=ld["imu_vs_laser"].delay_s)
        except ValueError as exc:
            notes.append(f"laser delay: {exc}")
    return out


def _margins(w, H, coherence, sweep: SweepSettings, notes: list[str]) -> dict:
    """Margins from points with coherence >= ``sweep.min_coherence``; a phase crossover found only
    below that is read from points down to ``gm_min_coherence`` and flagged in ``notes``."""
    out = {}
    try:
        m = margins_from_frd(w, H, coherence, sweep.min_coherence)
        out.update(pm_deg=m.pm_deg, w_gc=m.w_gc, gm_db=m.gm_db, w_pc=m.w_pc)
        if not np.isfinite(m.w_pc):
            g = margins_from_frd(w, H, coherence, sweep.gm_min_coherence)
            if np.isfinite(g.w_pc):
                i = np.argmin(np.abs(w - g.w_pc))
                out.update(gm_db=g.gm_db, w_pc=g.w_pc)
                notes.append(f"GM read at coherence {coherence[i]:.2f} (low confidence)")
    except ValueError as exc:
        notes.append(f"margins: {exc}")
    return out


def merge_sweeps(results: list[dict], sweep: SweepSettings) -> dict:
    """One result from the same sweep flown with several seeds: the broken-loop responses averaged
    per frequency with weights γ²/(1 − γ²) (the inverse variance of H, as CIPHER's composite
    windows weigh), whose sum S gives the merged coherence S/(1 + S) (the information of the
    records adds); margins from the merged response; delays inverse-variance averaged. A seed
    whose sweep did not complete is named in the notes and left out."""
    pm_seeds = [float(r["pm_deg"]) for r in results]
    if len(results) == 1:
        return dict(results[0], pm_seeds=pm_seeds,
                    **{f"{k}_estimates": _estimates(results, k) for k in ("delay_s", "laser_delay_s")})
    notes = [f"seed {i + 1}: {n}" for i, r in enumerate(results) for n in r["notes"]]
    out = dict(pm_deg=math.nan, w_gc=math.nan, gm_db=math.nan, w_pc=math.nan, notes=notes, pm_seeds=pm_seeds)
    for k in ("delay_s", "laser_delay_s"):
        out[f"{k}_estimates"] = est = _estimates(results, k)
        c = combine_delays(*zip(*est)) if est else combine_delays([], [])
        out[k], out[k[:-2] + "_std_s"] = c.delay_s, c.std_s
    il = np.array([r.get("imu_vs_laser_s", math.nan) for r in results], float)
    out["imu_vs_laser_s"] = float(np.nanmean(il)) if np.isfinite(il).any() else math.nan
    frfs = [r["frf"] for r in results if r.get("frf") is not None]
    if not frfs:
        return out
    w = frfs[0]["w"]
    if any(f["w"].shape != w.shape or not np.allclose(f["w"], w) for f in frfs):
        raise ValueError("sweeps to merge must share one frequency grid")
    g = np.clip(np.nan_to_num(np.array([f["coherence"] for f in frfs], float)), 0.0, 0.999)
    wt = g / (1.0 - g)
    S = wt.sum(axis=0)
    H = np.array([f["H"] for f in frfs])
    with np.errstate(invalid="ignore", divide="ignore"):
        Hm = np.where(S > 0, (wt * np.nan_to_num(H)).sum(axis=0) / S, np.nanmean(H, axis=0))
    coh = S / (1.0 + S)
    out["frf"] = dict(w=w, H=Hm, coherence=coh)
    out.update(_margins(w, Hm, coh, sweep, notes))
    return out


def _estimates(results: list[dict], key: str) -> list[tuple[float, float]]:
    """(delay, sigma) of each sweep (each seed) of ``key`` ("delay_s", "laser_delay_s")."""
    out = []
    for r in results:
        if f"{key}_estimates" in r:
            out.extend(r[f"{key}_estimates"])
        else:
            out.append((float(r.get(key, math.nan)), float(r.get(key[:-2] + "_std_s", math.nan))))
    return out


def _combine(*runs: dict, key: str = "delay_s", tolerance_s: float = 0.005) -> CombinedDelay:
    """``delay_id.combine_delays`` over every seed's estimate of ``key`` in ``runs`` (merged sweeps
    keep their seeds' estimates)."""
    est = _estimates(list(runs), key)
    return combine_delays(*zip(*est), tolerance_s=tolerance_s) if est else combine_delays([], [], tolerance_s)


def _call(kwargs: dict) -> dict:
    return sweep_run(**kwargs)


#: The identification sweep (flown on GPS, MPE open loop): starts at 0.4 Hz, where the vehicle no
#: longer drifts far enough to lose the tracked point, so it can be 1.6x the margins chirp; the
#: laser's pitch (range noise ~0.3° at 24 m) needs that amplitude for ±5 ms (±10 ms at 40 units).
IDENT_SWEEP = SweepSettings(amplitude=64.0, f0_hz=0.4, f1_hz=2.5, duration_s=40.0, start_s=1.0)


def check_margins_scenario(scenario: str, overrides=()) -> None:
    """The sweeps hover with a chirp at an actuator: only a ``mission.type = "hover"`` scenario fits.
    Any other raises ScenarioError naming the scenarios that do."""

    sc = load_scenario(scenario, list(overrides))
    if sc.mission.type != "hover":
        fit = [n for n in builtin_names() if load_scenario(n).mission.type == "hover"]
        raise ScenarioError(f"visnav margins flies hover sweeps: '{scenario}' is a '{sc.mission.type}' mission; "
                            f"it takes a scenario with mission.type = \"hover\" (built-in: {', '.join(fit)})")


def margins_campaign(altitudes, delays, compensate: bool = False, seed: int = 1,
                     sweep: SweepSettings = SweepSettings(), scenario: str = "palace-sweep",
                     overrides: tuple[str, ...] = (), workers: int = 1, executor=None,
                     progress=None, identify_altitude_m: float = 12.0, laser_delay_s: float = 0.0,
                     ident_sweep: SweepSettings = IDENT_SWEEP, seeds: int = 1,
                     frf_sink: dict | None = None, ident_seeds: int | None = None,
                     delay_tolerance_s: float = 0.005, min_delay_confidence: float = 0.9) -> list[dict]:
    """Tables 5.1/5.2: per altitude a GPS row and per IMU ``delay`` an MPE row, uncompensated;
    with ``compensate`` also an MPE row flown with the delays identified from a lateral and a
    longitudinal ``ident_sweep`` on GPS at ``identify_altitude_m`` (MPE open loop, so the identification
    never rides on a loop the delay may destabilise; once per delay, as the thesis identified its
    sensors once, on the ground): ``navigation.mpe.attitude_delay_s`` = the IMU's delay behind the
    camera, ``navigation.mpe.laser_delay_s`` = the laser's. Each delay is identified from
    ``ident_seeds`` seeds (default max(``seeds``, 4)) of both sweeps, every estimate with its
    coherence sigma, combined by ``delay_id.combine_delays`` (outliers dropped, weighted mean,
    sigma inflated by the seeds' scatter, ``confidence`` = P(|error| < ``delay_tolerance_s``)); a
    delay whose confidence is below ``min_delay_confidence`` is not compensated (0) and the row's
    notes say so. Rows carry ``identified_*_delay_s``, ``..._std_s`` and ``..._confidence``. ``laser_delay_s``: a simulated laser delay for
    every sweep. Each row is two sweeps (lateral, longitudinal). ``executor``: anything with
    ``submit`` (a process pool, a Dask client's executor); else ``workers`` local processes.
    ``seeds``: each sweep flown with seeds ``seed`` .. ``seed + seeds − 1`` and merged
    (``merge_sweeps``: where the MPE noise drowns the phase crossover of one record, several
    records average it out). ``progress(done, total)`` after each run. ``frf_sink``: a dict that
    receives each row's broken-loop responses, keyed (altitude, delay, compensated, axis)."""
    alts = [float(a) for a in altitudes]
    dls = [float(d) for d in delays]
    if not alts or any(not (np.isfinite(a) and a > 0) for a in alts):
        raise ValueError(f"altitudes must be a non-empty list of heights > 0 m, got {altitudes}")
    if any(not (np.isfinite(d) and d >= 0) for d in dls):
        raise ValueError(f"delays must be >= 0 s, got {delays}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if seeds < 1:
        raise ValueError(f"seeds must be >= 1, got {seeds}")
    n_ident = max(seeds, 4) if ident_seeds is None else int(ident_seeds)
    if n_ident < 1:
        raise ValueError(f"ident_seeds must be >= 1, got {ident_seeds}")
    if not (np.isfinite(delay_tolerance_s) and delay_tolerance_s > 0):
        raise ValueError(f"delay_tolerance_s must be > 0 s, got {delay_tolerance_s}")
    if not 0 <= min_delay_confidence <= 1:
        raise ValueError(f"min_delay_confidence must be in [0, 1], got {min_delay_confidence}")
    if not (np.isfinite(laser_delay_s) and 0 <= laser_delay_s <= 1):
        raise ValueError(f"laser_delay_s must be in [0, 1] s, got {laser_delay_s}")
    check_margins_scenario(scenario, overrides)
    base = dict(scenario=scenario, overrides=tuple(overrides), laser_delay_s=laser_delay_s)
    runs: dict[tuple, dict] = {}
    done = [0]

    def key(alt, src, delay, comp, axis, lcomp=0.0):
        return (alt, src, delay, round(comp, 6), axis, round(lcomp, 6))

    def execute(keys: list[tuple]) -> None:
        todo = [k for k in dict.fromkeys(keys) if k not in runs]
        n_of = {k: n_ident if k[1] == "ident" else seeds for k in todo}
        jobs = [dict(base, altitude_m=k[0], source="gps" if k[1] == "ident" else k[1], imu_delay_s=k[2],
                     attitude_delay_s=k[3], axis=k[4], laser_compensation_s=k[5], seed=seed + i,
                     sweep=ident_sweep if k[1] == "ident" else sweep) for k in todo for i in range(n_of[k])]
        pool = executor
        own = pool is None and workers > 1
        if own:
            pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))
        total = done[0] + len(jobs)
        try:
            futures = [pool.submit(_call, j) for j in jobs] if pool is not None else None
            j = 0
            for k in todo:
                res = []
                for _ in range(n_of[k]):
                    res.append(futures[j].result() if futures is not None else _call(jobs[j]))
                    j += 1
                    done[0] += 1
                    if progress is not None:
                        progress(done[0], total)
                runs[k] = merge_sweeps(res, jobs[j - 1]["sweep"])
        finally:
            if own:
                pool.shutdown()

    axes = ("lateral", "longitudinal")
    ia = float(identify_altitude_m)
    first = [key(a, "gps", 0.0, 0.0, ax) for a in alts for ax in axes]
    first += [key(a, "mpe", d, 0.0, ax) for a in alts for d in dls for ax in axes]
    if compensate:
        first += [key(ia, "ident", d, 0.0, ax) for d in dls for ax in axes]
    execute(first)
    ident = {}

    def comp_key(a, d, ax):
        ca, cl = _compensation(ident[d], min_delay_confidence)
        return key(a, "mpe", d, ca, ax, cl)

    if compensate:
        for d in dls:
            pair = [runs[key(ia, "ident", d, 0.0, ax)] for ax in axes]
            ident[d] = (_combine(*pair, tolerance_s=delay_tolerance_s),
                        _combine(*pair, key="laser_delay_s", tolerance_s=delay_tolerance_s))
        execute([comp_key(a, d, ax) for a in alts for d in dls for ax in axes])

    def row(a, delay, comp, pair, tau, ltau, notes):
        """``tau``, ``ltau``: the CombinedDelay of the IMU and of the laser."""
        r = dict(altitude_m=a, delay_s=delay, compensated=comp)
        for ax, res in zip(axes, pair):
            r.update({f"{ax}_pm_deg": res["pm_deg"], f"{ax}_pm_wc_rps": res["w_gc"], f"{ax}_gm_db": res["gm_db"]})
        r["identified_imu_delay_s"] = tau.delay_s
        r["identified_laser_delay_s"] = ltau.delay_s
        for name, c in (("imu", tau), ("laser", ltau)):
            r[f"identified_{name}_delay_std_s"] = c.std_s
            r[f"identified_{name}_delay_confidence"] = c.confidence
        for ax, res in zip(axes, pair):  # each seed's own PM: the spread the merged PM hides
            pm = np.array([p for p in res.get("pm_seeds", [res["pm_deg"]]) if np.isfinite(p)], float)
            r[f"{ax}_pm_seeds_deg"] = " ".join(f"{p:.1f}" for p in pm)
            r[f"{ax}_pm_seed_sd_deg"] = float(pm.std(ddof=1)) if pm.size > 1 else math.nan
        for ax, res in zip(axes, pair):
            r[f"{ax}_gm_wc_rps"] = res["w_pc"]
        r["notes"] = "; ".join(notes + [f"{ax}: {n}" for ax, res in zip(axes, pair) for n in res["notes"]])
        if frf_sink is not None:
            for ax, res in zip(axes, pair):
                if res.get("frf") is not None:
                    frf_sink[a, delay, comp, ax] = res["frf"]
        return r

    rows = []
    for a in alts:
        pair = [runs[key(a, "gps", 0.0, 0.0, ax)] for ax in axes]
        tol = dict(tolerance_s=delay_tolerance_s)
        rows.append(row(a, None, "gps", pair, _combine(*pair, **tol), _combine(*pair, key="laser_delay_s", **tol), []))
        for d in dls:
            pair = [runs[key(a, "mpe", d, 0.0, ax)] for ax in axes]
            rows.append(row(a, d, False, pair, _combine(*pair, **tol), _combine(*pair, key="laser_delay_s", **tol),
                            []))
            if compensate:
                tau, ltau = ident[d]
                pair = [runs[comp_key(a, d, ax)] for ax in axes]
                notes = [f"{name} delay not compensated: identified {c.delay_s * 1e3:.1f} ± {c.std_s * 1e3:.1f} ms, "
                         f"confidence {c.confidence:.2f} < {min_delay_confidence}"
                         for name, c in (("IMU", tau), ("laser", ltau)) if not c.usable(min_delay_confidence)]
                rows.append(row(a, d, True, pair, tau, ltau, notes))
    return rows


def _compensation(ident: tuple[CombinedDelay, CombinedDelay], min_confidence: float) -> tuple[float, float]:
    """(attitude_delay_s, laser_delay_s) for the navigator: each identified delay behind the camera
    where its confidence is at least ``min_confidence``, else 0 (no compensation: a wrong delay
    can cost more phase than none), clipped to the config's range."""
    a, b = (float(np.clip(c.delay_s, -0.5, 1.0)) if c.usable(min_confidence) else 0.0 for c in ident)
    return a, b
