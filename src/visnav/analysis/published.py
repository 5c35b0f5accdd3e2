"""The theses' published figures beside a run's metrics: one table, used by ``visnav run``'s summary and
by report.html (and by anything else that puts a thesis figure beside ours).

Each entry names the metric it compares with, the thesis' figure *with its conditions*, and, where the
thesis gives a number, the bound a verdict compares with ("meets" / "does not meet"; "n/a" where the
thesis gives no number or the quantity is not the same). Where the thesis measured over another
duration than a run flies, the entry normalises both to a rate (``per``): drift divided by the time it
accumulated over, scaled to a minute or to 120 s, as seed 000 §4.2.1 extrapolates its shorter hovers
linearly ("if anything, such a linear extrapolation overestimates the amount of drift").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

SOURCES = {"000": "seed 000 (Hubbard 2007)", "002": "seed 002 (Conte 2009)", "003": "seed 003 (Holmes 2017)",
           "004": "seed 004 (Svitelskyi 2019)"}


@dataclass(frozen=True)
class Published:
    """One thesis figure beside one of our metrics.

    ``figure``: the thesis' number in words, with where it is and under which conditions it was measured.
    ``limit``: the bound a verdict compares with (``None``: no verdict, "n/a"); ``better``: "lower" (ours
    <= limit meets) or "higher" (ours >= limit meets; booleans count as 1/0, a campaign's rate compares with
    the same limit). ``per`` = (metric holding the duration in s, seconds, unit): compare ours / duration x
    seconds, i.e. a rate, with a ``limit`` given in that unit. ``over`` = (metric, unit): what our value
    was measured over, shown beside it (a distance flown, a time)."""

    metric: str
    figure: str
    limit: float | None = None
    better: str = "lower"
    per: tuple[str, float, str] | None = None
    over: tuple[str, str] | None = None
    band: tuple[float, float] | None = None
    #: ``applies(scenario) -> bool``: the thesis figure describes this scenario's experiment (None: always);
    #: where it does not, the metric is not scored and ``unlike`` says why (issue #32: one frame against
    #: "RLS after 20-30 samples")
    applies: Callable | None = None
    unlike: str = ""


@dataclass(frozen=True)
class Row:
    metric: str
    ours: str
    thesis: str
    verdict: str


# ------------------------------------------------------------------------------------------- seed 000
#: Table 5.3: (MPE duration s, cumulative MPE drift m) of the 16 landings
TABLE_5_3 = [(438.3, 0.65), (365.6, 0.93), (477.6, 0.64), (285.9, 0.63), (337.4, 1.12), (382.0, 0.62),
             (357.1, 0.52), (357.4, 0.40), (306.8, 0.68), (486.2, 0.71), (310.6, 0.88), (327.4, 0.54),
             (301.8, 0.71), (300.4, 0.28), (251.4, 0.79), (321.6, 0.65)]
_RATES_5_3 = np.array([d / s * 60.0 for s, d in TABLE_5_3])

PALACE_LANDING = [
    Published("landed", "14 of 16 landings completed (88 %, Table 5.3)", limit=14 / 16, better="higher"),
    Published("touchdown_error_m", "no number: 'lands on the tracked point' (the error is MPE's drift)"),
    Published("mpe_drift_m",
              f"0.28-1.12 m (median 0.65) over 251-486 s of MPE, 16 landings (Table 5.3) = "
              f"{_RATES_5_3.min():.3f}-{_RATES_5_3.max():.3f} m/min (median {np.median(_RATES_5_3):.3f}); "
              "both as drift / MPE time, linear as §4.2.1",
              limit=float(_RATES_5_3.max()), per=("mpe_drift_duration_s", 60.0, "m/min")),
    Published("time_under_vision_s", "251-486 s of MPE per landing (Table 5.3, mostly hovering)"),
    Published("reinitializations", "'once or twice near the end' of a landing (§4.1)", limit=2),
]


#: Table 4.1 (flight, 120 s hovers unless shorter): (AGL m, surface, time s, drift m, sigma m, equiv px)
THESIS_TABLE_4_1 = [
    (30, "concrete", 120, 0.4626, 0.0635, 10.882), (30, "concrete", 120, 0.6137, 0.0810, 14.438),
    (31, "concrete", 76.2, 0.4802, 0.0761, 17.217), (19, "concrete", 120, 0.0848, 0.0581, 3.152),
    (14, "concrete", 120, 0.2346, 0.0434, 11.829), (12, "concrete", 34.3, 0.0789, 0.0227, 16.229),
    (18, "asphalt", 120, 0.3295, 0.0507, 12.917), (18, "asphalt", 120, 0.1880, 0.0541, 7.373),
    (12, "asphalt", 120, 0.1011, 0.0325, 5.945), (12, "asphalt", 120, 0.2548, 0.0289, 14.986),
    (12, "asphalt", 120, 0.3879, 0.0481, 22.812), (12, "asphalt", 120, 0.1991, 0.0354, 11.710),
    (6, "asphalt", 120, 0.0600, 0.0218, 7.057), (6, "asphalt", 120, 0.0217, 0.0176, 2.560),
    (4.5, "asphalt", 120, 0.0360, 0.0152, 5.650), (3.5, "asphalt", 120, 0.0769, 0.0164, 15.497),
    (2, "asphalt", 120, 0.0560, 0.0224, 19.770), (24, "grass", 107.6, 0.0735, 0.0793, 2.411),
    (17, "grass", 72.1, 0.2167, 0.1711, 14.971),
]


def _table_4_1_rows(altitude_m: float, surface: str):
    return [r for r in THESIS_TABLE_4_1 if r[1] == surface and abs(r[0] - altitude_m) <= 1.5]


def palace_hover(sc) -> list[Published]:
    """§4.2 drift figures for an open-loop (GPS) hover; none for an MPE hover or a sweep (its margins
    come from ``visnav margins``, see ``notes``)."""
    m = sc.mission
    if m.source != "gps" or m.sweep_axis != "none":
        return []
    out = [Published("drift_px", "at most 22.8 px in 120 s in flight (Table 4.1, Fig. 4.4); simulation "
                                 "20 px mean, 34 px max per 120 s (Figs. 4.2-4.3)",
                     limit=22.8, per=("drift_duration_s", 120.0, "px/120 s"))]
    rows = _table_4_1_rows(m.altitude_m, sc.world.surface)
    where = f"at {m.altitude_m:g} m over {sc.world.surface}"
    if rows:  # Table 4.1 gives the drift itself; rescale the shorter hovers to 120 s as Fig. 4.4 does
        d = np.array([r[3] * 120.0 / r[2] for r in rows])
        s = np.array([r[4] for r in rows])
        n = f"{len(rows)} flight{'s' if len(rows) > 1 else ''} {where} (Table 4.1)"
        out.append(Published("drift_m", f"{d.min():.3f}-{d.max():.3f} m per 120 s, {n}", limit=float(d.max()),
                             per=("drift_duration_s", 120.0, "m/120 s")))
        out.append(Published("mpe_noise_sigma_m", f"sigma {s.min():.3f}-{s.max():.3f} m, {n}", limit=float(s.max())))
    else:
        out.append(Published("drift_m", f"Table 4.1 has no flight {where}: compare drift_px"))
    return out


# ------------------------------------------------------------------------------------------- seed 002
PFCM = [
    Published("cross_track_rms_m", "std 0.5-1.3 m at 10 m/s in 2-4 m/s wind, on the INS/GPS solution (Table 4.1)",
              limit=1.3),
    Published("cross_track_max_m", "max 1.8-4.1 m at 10 m/s in 2-4 m/s wind (Table 4.1)", limit=4.1),
    Published("max_roll_deg", "bank limit phi_max = 15 deg (§4.3.3)", limit=15.0),
    Published("vrs_limit_exceeded_s", "descent within 1.5 m/s above 30 deg, 3 m/s below (eq. 4.23): 0 s over",
              limit=0.0),
]
WITAS = [
    Published("pmf_error_max_m", "below 8 m throughout the ~1 km loop at 60 m AGL (Fig. 5.18)", limit=8.0,
              over=("path_length_m", "m flown")),
    Published("pmf_error_rms_m", "no RMS given (the curve stays mostly below 5 m, Fig. 5.18)",
              over=("path_length_m", "m flown")),
    Published("odometry_drift_pct", "25 m in ~1 km = 2.5 % of the distance flown (Fig. 5.18)", limit=2.5,
              over=("path_length_m", "m flown")),
    Published("ins_only_error_final_m", "no number: stand-alone INS drifts hundreds of m (Fig. 5.18)"),
    Published("velocity_error_rms_mps", "horizontal velocity error mostly below 1 m/s (Fig. 5.18)", limit=1.0),
    Published("heading_error_final_deg", "no number: heading drifts without a compass (Fig. 5.19)"),
    Published("path_length_m", "a closed loop of about 1 km at 60 m AGL (§5.9.1)"),
    Published("returned_home", "the helicopter closes the loop at home (Fig. 5.17)", limit=1.0, better="higher"),
]

# ------------------------------------------------------------------------------------------- seed 003
DECK = [
    Published("landed", "64 static-deck and 20 moving-deck flights, all landed (§5.3.3, §5.3.5)", limit=1.0,
              better="higher"),
    Published("touchdown_rel_speed_mps", "not reported"),
    Published("touchdown_attitude_mismatch_deg", "not reported"),
    Published("touchdown_position_error_m", "not the same quantity: touchdown *estimate* errors 'on the order "
                                            "of a centimeter' (§6.1)"),
    Published("pos_error_final_approach_median_m", "generally below 10 cm on the approach, 20 moving-deck "
                                                   "flights (Fig. 5.20)", limit=0.10),
    Published("att_error_final_approach_median_deg", "0.08-0.12 rad = 4.6-6.9 deg on the approach, 20 "
                                                     "moving-deck flights (Fig. 5.20)", limit=6.9),
    Published("vel_error_final_approach_median_mps", "about 0.2 m/s on the approach, 20 moving-deck flights "
                                                     "(Fig. 5.21)", limit=0.2),
    Published("nees_mean", "errors inside +-2 sigma (Figs. 5.12-5.15); consistent when in the 95 % chi2(12) "
                           "band 4.40-23.34", band=(4.404, 23.337)),
]

# ------------------------------------------------------------------------------------------- seed 004
CONDOR_GROUND = [
    Published("radius_est_error_max_pct", "peak 8.94 % on the flight hardware (Table 4.1; ch. 8: 'as high as 9 %')",
              limit=8.94),
    Published("thesis_mean_abs_error_pct", "mean |error| 3.6 % over the 12 rows of Tables 4.1-4.2 (ch. 8: "
                                           "'does not exceed 3 %')", limit=3.6),
    Published("thesis_max_abs_error_pct", "8.94 % (Table 4.1)", limit=8.94),
    Published("ours_mean_abs_error_pct", "mean |error| 3.6 % over the 12 rows of Tables 4.1-4.2", limit=3.6),
    Published("ours_max_abs_error_pct", "8.94 % (Table 4.1)", limit=8.94),
]
CONDOR_ORBIT = [
    Published("radius_est_error_max_pct", "in flight 'occasionally up to 20-40 %' in strong wind (ch. 8)",
              limit=40.0),
    Published("radius_est_error_rms_pct", "no number: 'measurements were mostly accurate' (ch. 8)"),
    Published("orbit_radius_error_rms_m", "no number: original controller drifts downwind (Figs. 7.4-7.5), "
                                          "modified: small error (Fig. 7.10)"),
    Published("orbit_radius_error_max_m", "no number: SITL at 8 kt, stable but shifted orbit (Fig. 6.1)"),
    Published("tracking_lost_s", "4 s lost in flight 1 (seconds 54-58, Fig. 7.1)", limit=4.0),
]


# ------------------------------------------------------------------------------------------- seed 002 ch. 6-7
PAD = [
    Published("landed", "§6.3: autonomous landings from about 20 m completed, GPS not used", limit=1, better="higher"),
    Published("vision_lost_height_m", "Fig. 6.11: the pattern left the view at about 0.6 m; the filter carried the "
                                      "landing (0.4-1.0 m counts as 'about')", band=(0.4, 1.0)),
    Published("vision_velocity_error_rms_mps", "Figs. 6.6-6.8: velocity from differentiated vision noisy, most at "
                                               "~15 m (no number)"),
    Published("velocity_error_rms_mps", "Figs. 6.6-6.8: filter velocity low-noise and low-latency (no number)"),
    Published("vision_attitude_error_rms_deg", "Figs. 6.9-6.10: vision roll/pitch biased by the camera platform "
                                               "misalignment (no number)"),
    Published("attitude_error_rms_deg", "Figs. 6.9-6.10: filter roll/pitch free of the mount bias (no number)"),
    Published("touchdown_error_m", "not given in the thesis"),
    Published("touchdown_speed_mps", "not given in the thesis"),
]

def _many_frames(sc) -> bool:
    return getattr(sc.mission, "experiment", "") != "single_frame"


_ONE_FRAME = "this run geo-locates from one frame (§7.5); the figure is of an RLS over 20-30 samples"
GEOLOCATION = [
    Published("target_error_m", "2.3 m: RLS of the registration samples after 20-30 samples (Fig. 7.9)", limit=2.3,
              applies=_many_frames, unlike=_ONE_FRAME),
    Published("map_based_error_m", "about 22 m: RLS of the map-based samples on the same data (Fig. 7.11); "
                                   "depends on the attitude errors of that airframe (no verdict)"),
    Published("false_match_rate", "sporadic false matches on the repetitive road system (Fig. 7.8; no number)"),
    Published("samples_to_3m", "the RLS error settles after 20-30 samples (Fig. 7.9)", limit=30,
              applies=_many_frames, unlike=_ONE_FRAME),
    Published("single_frame_error_median_m", "competition flight (MAV07): one noisy frame, 4 m (§7.5)", limit=4.0),
]


def published(sc) -> tuple[list[Published], str]:
    """The published figures that apply to a scenario, and which thesis they come from."""
    figs, source = _published(sc)
    return [p for p in figs if p.applies is None or p.applies(sc)], source


def not_compared(sc) -> dict[str, str]:
    """metric -> why its thesis figure does not describe this scenario (its metric is not scored)."""
    return {p.metric: p.unlike for p in _published(sc)[0] if p.applies is not None and not p.applies(sc)}


def _published(sc) -> tuple[list[Published], str]:
    kind = getattr(sc.mission, "type", "")
    if kind == "palace":
        return PALACE_LANDING, SOURCES["000"]
    if kind == "hover":
        return palace_hover(sc), SOURCES["000"]
    if kind == "pfcm":
        return PFCM, SOURCES["002"]
    if kind == "witas-homing":
        return WITAS, SOURCES["002"]
    if kind == "deck":
        return DECK, SOURCES["003"]
    if kind == "pad-landing":
        return PAD, SOURCES["002"] + " ch. 6"
    if kind == "mav-geolocation":
        return GEOLOCATION, SOURCES["002"] + " ch. 7"
    if kind == "condor":
        return (CONDOR_GROUND if sc.mission.experiment == "ground_test" else CONDOR_ORBIT), SOURCES["004"]
    return [], ""


# ------------------------------------------------------------------------------------------- rows
_UNITS = (("_pct", "%"), ("_mps", "m/s"), ("_deg", "deg"), ("_px", "px"), ("_m", "m"), ("_s", "s"))


def unit_of(metric: str) -> str:
    """The unit a metric's name ends in (``_m`` -> m, ``_mps`` -> m/s, ...), "" when none."""
    return next((u for suffix, u in _UNITS if metric.endswith(suffix)), "")


def _missing(v) -> bool:
    return v is None or (isinstance(v, float) and math.isnan(v))


def fmt(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        return f"{v:.3f}"
    return str(v)


def _bound(p: Published, unit: str) -> str:
    return f"{p.limit:.3g} {unit}".strip()


def verdict(p: Published, value: float) -> str:
    """"meets (<= bound)" / "does not meet (> bound)" / "n/a" for one value (already normalised)."""
    if p.band is not None:
        lo, hi = p.band
        ok = lo <= value <= hi
        return f"{'meets' if ok else 'does not meet'} ({'inside' if ok else 'outside'} {lo:g}-{hi:g})"
    if p.limit is None or _missing(value):
        return "n/a"
    unit = p.per[2] if p.per else unit_of(p.metric)
    if isinstance(value, (bool, np.bool_)):  # one run of a rate: a campaign compares the rate with the limit
        return "meets" if (float(value) >= p.limit if p.better == "higher" else float(value) <= p.limit) \
            else "does not meet"
    by = f", by {abs(value - p.limit):.3g} {unit}".rstrip()  # how far past the bound (issue #32: 15.6 deg vs 15)
    if p.better == "higher":
        return f"meets (>= {_bound(p, unit)})" if value >= p.limit else f"does not meet (< {_bound(p, unit)}{by})"
    return f"meets (<= {_bound(p, unit)})" if value <= p.limit else f"does not meet (> {_bound(p, unit)}{by})"


def row(p: Published | None, metric: str, value, metrics: dict) -> Row:
    ours = fmt(value)
    if p is None:
        return Row(metric, ours, "", "")
    unit = unit_of(metric)
    x = value if isinstance(value, (bool, np.bool_)) else (
        float(value) if isinstance(value, (int, float, np.number)) else math.nan)
    if p.per is not None:
        key, seconds, per_unit = p.per
        dur = metrics.get(key)
        if _missing(dur) or not dur or dur <= 0:
            return Row(metric, ours, p.figure, "n/a (no duration to compare over)")
        x = x / float(dur) * seconds
        ours = f"{fmt(value)} {unit} over {float(dur):.1f} s = {x:.3f} {per_unit}"
    elif p.over is not None and not _missing(metrics.get(p.over[0])):
        ours = f"{ours} (over {float(metrics[p.over[0]]):.0f} {p.over[1]})"
    return Row(metric, ours, p.figure, verdict(p, x))


def summary_rows(sc, metrics: dict) -> tuple[list[Row], list[str], str]:
    """(rows of metric / ours / thesis / verdict, metrics left out because they do not apply to this run
    (NaN or None), which thesis). Rows keep the order of ``metrics``."""
    figs, source = published(sc)
    by_metric = {p.metric: p for p in figs}
    unlike = not_compared(sc)
    rows, omitted = [], []
    for k, v in metrics.items():
        if k == "provenance" or isinstance(v, (dict, list, tuple)):  # lists (sil_notes) print as lines: run_notes
            continue
        if _missing(v):
            omitted.append(k)
            continue
        if k in unlike:
            rows.append(Row(k, fmt(v), f"not compared: {unlike[k]}", "not scored"))
            continue
        rows.append(row(by_metric.get(k), k, v, metrics))
    return rows, omitted, source


def notes(sc) -> list[str]:
    """Lines a run's summary and report add below the table."""
    m = sc.mission
    if getattr(m, "type", "") == "hover" and m.sweep_axis != "none":
        return ["This run flies one chirp; the stability margins of Tables 5.1/5.2 come from "
                f"`visnav margins {sc.run.name}`, which flies the sweeps and identifies the loop."]
    return []
