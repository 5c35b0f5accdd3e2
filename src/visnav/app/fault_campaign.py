"""``visnav faults SCENARIO --faults all -n N``: every fault that applies to a scenario, on N seeds, plus the
fault-free case (issue #18).

Each fault is one ``app/montecarlo.Campaign`` in ``DIR/<fault>/`` (the scenario with
``faults=[{...}]`` added to its overrides): runs, resume, ``--new`` and Ctrl-C are the Monte Carlo
runner's. ``DIR/faults.csv`` (one row per fault, ``none`` first) and ``DIR/faults.md`` are written from
the sub-campaigns' ``runs.csv`` (the integrity metrics of ``analysis/integrity_metrics.py``).

The faults and their timing per mission (``FAULT_SETS``) are placed where each mission depends on the
faulted sensor: PALACE during the MPE descent (about 40-67 s), the WITAS homing along the loop after GPS
loss (8 s), the pad landing during the approach, the deck landing from 9 s (deck-moving: the end of the
5 s hover and the tau approach, which starts at 8.5-14 s; deck-static: inside its 15 s approach from 5 s;
the whole deck flight is flown on the vision UKF), CONDOR on the vision orbit (from 60 s; faults at 100 s,
after its 40 s transition, the GPS walk-off from 70 s: GPS is then only the fallback's). ``feature_poor`` and ``map_offset`` are build-time
faults: their ``start_s`` is when the vehicle is expected to reach the area / when the vision navigator
engages, the instant the detection delay is measured from.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
from visnav.app.montecarlo import Campaign
from visnav.scenarios.schema import load_scenario

FAULT_COLUMNS = ("fault", "runs", "detected_share", "detection_delay_s", "false_alarms", "safe", "unsafe",
                 "over_hpl_while_ok_pct", "worst_error_while_ok_m")

_CAM = dict(duration_s=3.0)
FAULT_SETS: dict[str, list[dict]] = {
    "palace": [
        dict(kind="camera_blackout", start_s=50.0, **_CAM),
        dict(kind="camera_frozen", start_s=50.0, **_CAM),
        dict(kind="camera_brightness", start_s=50.0, duration_s=10.0, gain=1.6, offset_dn=40.0),
        dict(kind="camera_blur", start_s=50.0, duration_s=5.0, blur_px=9),
        dict(kind="imu_gyro_bias", start_s=45.0, duration_s=20.0, bias=[0.5, 0.5, 0.5]),
        dict(kind="imu_accel_bias", start_s=45.0, duration_s=20.0, bias=[0.3, 0.3, 0.0]),
        dict(kind="imu_drop", start_s=50.0, duration_s=5.0, drop_probability=0.5),
        dict(kind="clock_jump", sensor="laser", start_s=50.0, duration_s=5.0, jump_s=0.2),
        dict(kind="range_dropout", sensor="laser", start_s=50.0, duration_s=3.0),
        dict(kind="range_stuck", sensor="laser", start_s=50.0, duration_s=5.0),
        dict(kind="gps_spoof", start_s=15.0, duration_s=15.0, walk_mps=0.5, walk_deg=90.0, lost_after=True),
        dict(kind="wind_gust", start_s=50.0, duration_s=4.0, speed_mps=8.0, from_deg=90.0),
    ],
    "witas-homing": [
        dict(kind="camera_blackout", start_s=60.0, duration_s=5.0),
        dict(kind="camera_frozen", start_s=60.0, duration_s=5.0),
        dict(kind="camera_brightness", start_s=60.0, duration_s=10.0, gain=1.6, offset_dn=40.0),
        dict(kind="camera_blur", start_s=60.0, duration_s=10.0, blur_px=9),
        dict(kind="imu_gyro_bias", start_s=60.0, duration_s=20.0, bias=[0.5, 0.5, 0.5]),
        dict(kind="imu_accel_bias", start_s=60.0, duration_s=20.0, bias=[0.3, 0.3, 0.0]),
        dict(kind="imu_drop", start_s=60.0, duration_s=5.0, drop_probability=0.5),
        dict(kind="clock_jump", sensor="camera", start_s=60.0, duration_s=5.0, jump_s=0.2),
        dict(kind="gps_spoof", start_s=2.0, duration_s=6.0, walk_mps=1.0, walk_deg=90.0, lost_after=True),
        dict(kind="map_offset", start_s=8.0, offset_m=[10.0, 0.0], label="map_offset_10m"),
        dict(kind="map_offset", start_s=8.0, offset_m=[20.0, 0.0], label="map_offset_20m"),
        dict(kind="feature_poor", start_s=45.0, centre_m=[160.0, 0.0], size_m=[80.0, 80.0]),
        dict(kind="wind_gust", start_s=60.0, duration_s=4.0, speed_mps=8.0, from_deg=90.0),
    ],
    "pad-landing": [
        dict(kind="camera_blackout", start_s=15.0, **_CAM),
        dict(kind="camera_frozen", start_s=15.0, **_CAM),
        dict(kind="camera_brightness", start_s=15.0, duration_s=10.0, gain=1.6, offset_dn=40.0),
        dict(kind="camera_blur", start_s=15.0, duration_s=5.0, blur_px=9),
        dict(kind="imu_gyro_bias", start_s=15.0, duration_s=10.0, bias=[0.5, 0.5, 0.5]),
        dict(kind="imu_accel_bias", start_s=15.0, duration_s=10.0, bias=[0.3, 0.3, 0.0]),
        dict(kind="imu_drop", start_s=15.0, duration_s=5.0, drop_probability=0.5),
        dict(kind="clock_jump", sensor="camera", start_s=15.0, duration_s=3.0, jump_s=0.2),
        dict(kind="wind_gust", start_s=15.0, duration_s=4.0, speed_mps=8.0, from_deg=90.0),
    ],
    # deck-static and deck-moving (the LED camera renders an image; the IMU is accelerometers + gyros)
    "deck": [
        dict(kind="camera_blackout", start_s=9.0, duration_s=2.0),
        dict(kind="camera_frozen", start_s=9.0, duration_s=2.0),
        dict(kind="camera_brightness", start_s=9.0, duration_s=3.0, gain=1.6, offset_dn=40.0),
        dict(kind="camera_blur", start_s=9.0, duration_s=3.0, blur_px=9),
        dict(kind="imu_gyro_bias", start_s=9.0, duration_s=5.0, bias=[0.5, 0.5, 0.5]),
        dict(kind="imu_accel_bias", start_s=9.0, duration_s=5.0, bias=[0.3, 0.3, 0.0]),
        dict(kind="imu_drop", start_s=9.0, duration_s=3.0, drop_probability=0.5),
        dict(kind="clock_jump", sensor="camera", start_s=9.0, duration_s=3.0, jump_s=0.2),
        dict(kind="wind_gust", start_s=9.0, duration_s=2.0, speed_mps=3.0, from_deg=90.0),
    ],
    "condor": [
        dict(kind="camera_blackout", start_s=100.0, duration_s=5.0),
        dict(kind="camera_frozen", start_s=100.0, duration_s=5.0),
        dict(kind="camera_brightness", start_s=100.0, duration_s=10.0, gain=1.6, offset_dn=40.0),
        dict(kind="camera_blur", start_s=100.0, duration_s=10.0, blur_px=9),
        dict(kind="imu_gyro_bias", start_s=100.0, duration_s=20.0, bias=[0.5, 0.5, 0.5]),
        dict(kind="imu_accel_bias", start_s=100.0, duration_s=20.0, bias=[0.3, 0.3, 0.0]),
        dict(kind="imu_drop", start_s=100.0, duration_s=5.0, drop_probability=0.5),
        dict(kind="clock_jump", sensor="camera", start_s=100.0, duration_s=5.0, jump_s=0.2),
        dict(kind="gps_spoof", start_s=70.0, duration_s=30.0, walk_mps=1.0, walk_deg=90.0, lost_after=False),
        dict(kind="wind_gust", start_s=100.0, duration_s=4.0, speed_mps=8.0, from_deg=90.0),
    ],
}


def _toml_inline(d: dict) -> str:
    def v(x):
        if isinstance(x, bool):
            return "true" if x else "false"
        if isinstance(x, str):
            return '"' + x + '"'
        if isinstance(x, (list, tuple)):
            return "[" + ", ".join(v(y) for y in x) + "]"
        return repr(float(x)) if isinstance(x, float) else repr(x)

    return "{" + ", ".join(f"{k} = {v(x)}" for k, x in d.items()) + "}"


def fault_name(d: dict) -> str:
    return d.get("label") or d["kind"]


def faults_for(scenario: str, overrides: list[str], names: list[str]) -> list[dict]:
    """The fault definitions to run: ``names == ["all"]`` every one of the scenario's mission, else those
    named (by kind or label). ValueError (one line) for a mission without a fault set or an unknown name."""

    mtype = load_scenario(scenario, overrides).mission.type
    if mtype not in FAULT_SETS:
        raise ValueError(f"no fault set for mission.type {mtype!r}; fault campaigns exist for "
                         f"{', '.join(FAULT_SETS)}")
    every = FAULT_SETS[mtype]
    if names in (["all"], []):
        return list(every)
    known = {fault_name(d): d for d in every} | {d["kind"]: d for d in every}
    bad = [n for n in names if n not in known and n != "none"]
    if bad:
        raise ValueError(f"unknown fault {', '.join(bad)} for {mtype}; known: {', '.join(fault_name(d) for d in every)}")
    return [known[n] for n in names if n != "none"]


def campaigns(scenario: str, n: int, out: Path, faults: list[dict], overrides: list[str], workers: int,
              first_seed: int = 1):
    """(name, Campaign) for the fault-free case and each fault."""
    seeds = list(range(first_seed, first_seed + n))
    out = Path(out)
    yield "none", Campaign(scenario, seeds, out / "none", list(overrides), {}, workers)
    for d in faults:
        yield fault_name(d), Campaign(scenario, seeds, out / fault_name(d),
                                      list(overrides) + [f"faults=[{_toml_inline(d)}]"], {}, workers)


def _num(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def fault_row(name: str, rows: list[dict]) -> dict:
    ok = [r for r in rows if r.get("status") == "ok" or r.get("outcome")]
    delays = [d for d in (_num(r.get("detection_delay_s")) for r in ok) if math.isfinite(d)]
    worst = [w for w in (_num(r.get("worst_error_while_ok_m")) for r in ok) if math.isfinite(w)]
    injected = sum(_num(r.get("faults_injected")) > 0 for r in ok)
    viol = sum(v for v in (_num(r.get("hpl_bound_violations")) for r in ok) if math.isfinite(v))
    samples = sum(v for v in (_num(r.get("hpl_samples_ok")) for r in ok) if math.isfinite(v))
    detected = sum(_num(r.get("faults_detected")) > 0 for r in ok)
    return {
        "fault": name, "runs": len(rows),
        "detected_share": (detected / injected) if injected else float("nan"),
        "detection_delay_s": float(np.median(delays)) if delays else float("nan"),
        # alarms the mission acted on (fallback, abort, go-around) outside the fault's window: the ones that
        # can change an outcome; the navigator's own are in navigator_alarms (faults.md)
        "false_alarms": int(sum(_num(r.get("false_alarm_actions")) for r in ok
                                if math.isfinite(_num(r.get("false_alarm_actions"))))),
        "navigator_alarms": int(sum(_num(r.get("false_alarms")) for r in ok if math.isfinite(_num(r.get("false_alarms"))))),
        "safe": sum(r.get("outcome") in ("safe", "aborted") for r in rows),  # an abort is the safe reaction
        # a failed run without an outcome counts unsafe (analysis/outcome.py: the outcomes)
        "unsafe": sum(r.get("outcome") not in ("safe", "aborted", "not_applicable") for r in rows),
        # mission steps whose true horizontal error exceeded the HPL while the navigator said `ok`, in % of the
        # steps it said `ok` (issue #30: <= 0.1 % under every fault and without one)
        "over_hpl_while_ok_pct": (100.0 * viol / samples) if samples else float("nan"),
        "worst_error_while_ok_m": max(worst) if worst else float("nan"),
    }


def write_tables(out: Path, table: list[dict], extra: dict[str, list[dict]], scenario: str, n: int) -> None:
    out = Path(out)
    with (out / "faults.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FAULT_COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in table:
            w.writerow({k: ("" if isinstance(r[k], float) and math.isnan(r[k]) else
                            (f"{r[k]:.3g}" if isinstance(r[k], float) else r[k])) for k in FAULT_COLUMNS})
    lines = [f"# Fault campaign: {scenario}, {n} seeds per fault", "",
             "| " + " | ".join(FAULT_COLUMNS) + " |", "|" + "---|" * len(FAULT_COLUMNS)]
    for r in table:
        lines.append("| " + " | ".join("" if isinstance(r[k], float) and math.isnan(r[k]) else
                                       (f"{r[k]:.3g}" if isinstance(r[k], float) else str(r[k]))
                                       for k in FAULT_COLUMNS) + " |")
    none = extra.get("none", [])
    if none:
        viol = sum(_num(r.get("hpl_bound_violations")) for r in none)
        samples = sum(_num(r.get("hpl_samples_ok")) for r in none)
        acts = sum(_num(r.get("false_alarm_actions")) for r in none)
        navs = sum(_num(r.get("false_alarms")) for r in none)
        lines += ["", f"Fault-free: HPL exceeded by the true horizontal error in {int(viol)} of {int(samples)} "
                      f"mission steps while `ok` ({100 * viol / samples if samples else float('nan'):.3f} %); "
                      f"{int(acts)} false alarms the mission acted on (fallback, abort, go-around); "
                      f"{int(navs)} navigator alarms outside a fault (state left `ok`) that it did not need to act on."]
    lines += ["", "`false_alarms`: alarms the mission acted on outside the fault's window (+5 s); navigator alarms "
                  "per fault: " + ", ".join(f"{r['fault']} {r['navigator_alarms']}" for r in table) + ".",
              "", "Per run (outcome and reason):", ""]
    for name, rows in extra.items():
        for r in rows:
            delay = _num(r.get("detection_delay_s"))
            said = ("no fault injected" if name == "none" else
                    f"detected after {delay:.2f} s" if math.isfinite(delay) else "not detected")
            lines.append(f"- {name} seed {r.get('seed')}: {r.get('outcome', r.get('status'))}"
                         f" ({r.get('outcome_reason', r.get('error', ''))}), {said}")
    lines += ["", "Definitions: `analysis/integrity_metrics.py`; faults and timing: `app/fault_campaign.py`."]
    (out / "faults.md").write_text("\n".join(lines) + "\n")
