"""Integrity metrics of a run, from its log and the resolved scenario (issue #18).

Inputs (``FlightLog`` or the same data read back from ``log.h5``): ``status`` (``integrity`` code 0 ok /
1 degraded / 2 unusable, ``hpl_m``) logged with ``truth`` and ``estimate`` at each mission step; the
``mode``, ``integrity_event`` and ``integrity_reaction`` streams; ``touchdown``; ``witas_setup`` (home);
``error``. metrics.json is flat, so the time per state is ``integrity_time_ok_s`` / ``_degraded_s`` /
``_unusable_s`` (the issue's ``integrity_state_time_s``).

Definitions:

* an *alarm* is the navigator leaving ``ok`` (an ``integrity_event`` with state > 0, once it has been ok),
  an ``integrity_reaction`` of the mission, or a safety mode change of the mission (``abort``,
  ``go-around``, or PALACE's MPE -> GPS fallback: ``verify`` entered from ``descend_mpe`` / ``hold``);
  ``false_alarm_actions`` counts only the mission's flight-changing ones (fallback, abort, go-around)
  outside the fault windows: a navigator alarm the mission rightly ignores (the pad landing's last
  half metre, where the pattern leaves the view by design) is in ``false_alarms`` only;
* a fault is *detected* when an alarm falls in ``[start_s, end_s + detect_grace_s]``; its delay is the
  first such alarm minus ``start_s``; a *false alarm* is an alarm outside every fault's window + grace;
* ``hpl_bound_violations``: mission steps where the true horizontal error exceeds the HPL while ``ok``
  (``hpl_samples_ok``: the ok steps it is counted over);
* ``outcome`` (``unsafe`` as the issue defines it): a landing more than 1 m from its point or faster
  than 1 m/s, a crash (ground contact of a mission that does not land, an exception), or a homing that
  ends more than 30 m from home while claiming ``ok``; ``safe`` otherwise. The deck (seed 003): a
  touchdown off the plate (the thesis' "landed" is on the plate, all 84 flights), more than 1 m from the
  landing point or faster than 1 m/s relative to the deck (``touchdown`` stream); no touchdown (held,
  went around) is safe. CONDOR (seed 004): the 5 m floor (the run stops on an exception) or, on the vision
  orbit after its ``transition_s`` and while the navigator claims ``ok``, a true orbit radius more than
  ``ORBIT_RADIUS_BOUND_M`` (30 m, 27 % of the 110 m orbit; fault-free the error stays below 12 m) from
  ``radius_m``.

For the deck the "horizontal" error of the HPL is that of the relative position (the deck origin seen
from the vehicle, body FRD x and y: ``truth.position`` / ``estimate.position`` of the deck streams), the
plane of the UKF's ``P[0:2, 0:2]`` the HPL is computed from; for CONDOR it is the NED position of
``estimate`` (smoothed GPS in the loiter, eq. 3.23-3.24 on the vision orbit) against truth.
"""

from __future__ import annotations

import math

import numpy as np

DETECT_GRACE_S = 5.0
LANDING_RADIUS_M = 1.0
LANDING_SPEED_MPS = 1.0
HOMING_RADIUS_M = 30.0
ORBIT_RADIUS_BOUND_M = 30.0  # CONDOR: true orbit radius error while claiming ok on the vision orbit


FLIGHT_ACTIONS = ("fallback", "abort", "go-around")


def _alarms(log, navigator: bool = True) -> list[float]:
    """Alarm times: the navigator's (``navigator``) and the mission's flight-changing reactions."""
    out: list[float] = []
    ev = log.get("integrity_event")
    if ev and navigator:
        seen_ok = False
        for t, s in zip(ev["t"], ev["state"]):
            if int(s) == 0:
                seen_ok = True
            elif seen_ok:
                out.append(float(t))
    re = log.get("integrity_reaction")
    if re:
        out += [float(t) for t, a in zip(re["t"], re["action"]) if str(a) in FLIGHT_ACTIONS]
    md = log.get("mode")
    if md:
        prev = md.get("previous", [""] * len(md["t"]))
        for t, m, p in zip(md["t"], md["mode"], prev):
            if str(m) in ("abort", "go-around") or (str(m) == "verify" and str(p) in ("descend_mpe", "hold")):
                out.append(float(t))
    return sorted(out)


def _outcome(log, scenario, code_last: int | None) -> tuple[str, str]:
    mtype = getattr(scenario.mission, "type", "palace")
    if log.get("error"):
        return "unsafe", "the run stopped on an exception"
    td = log.get("touchdown")
    if mtype == "deck":
        if not td:
            return "safe", "no touchdown (held or went around)"
        d, v, on = (float(np.asarray(td[k], float)[0]) for k in ("pos_err", "rel_speed", "on_deck"))
        what = f"touched down {d:.2f} m from the point at {v:.2f} m/s" + (" on the plate" if on else " off the plate")
        if not on or d > LANDING_RADIUS_M or (math.isfinite(v) and v > LANDING_SPEED_MPS):
            return "unsafe", what
        return "safe", what
    if mtype == "condor":
        return _condor_outcome(log, scenario)
    if mtype in ("palace", "pad-landing"):
        if not td:
            return "safe", "no landing (held or aborted)"
        point = np.array(scenario.mission.landing_point_m[:2] if mtype == "palace" else [0.0, 0.0], float)
        d = float(np.hypot(*(np.asarray(td["position"], float)[0][:2] - point)))
        v = float(np.asarray(td["speed"], float)[0])
        if d > LANDING_RADIUS_M or (math.isfinite(v) and v > LANDING_SPEED_MPS):
            return "unsafe", f"landed {d:.2f} m from the point at {v:.2f} m/s"
        return "safe", f"landed {d:.2f} m from the point at {v:.2f} m/s"
    if td:
        return "unsafe", "ground contact"
    if mtype == "witas-homing":
        setup, tr = log.get("witas_setup"), log.get("truth")
        if setup and tr:
            home = np.asarray(setup["home"], float)[0]
            d = float(np.hypot(*(np.asarray(tr["position"], float)[-1][:2] - home[:2])))
            if d > HOMING_RADIUS_M and code_last == 0:
                return "unsafe", f"ended {d:.1f} m from home claiming ok"
            return "safe", f"ended {d:.1f} m from home" + (" claiming ok" if code_last == 0 else " (not claiming ok)")
    return "safe", ""


def _condor_outcome(log, scenario) -> tuple[str, str]:
    st, tr = log.get("status"), log.get("truth")
    cfg = scenario.mission
    if getattr(cfg, "experiment", "orbit") != "orbit" or not st or not tr or "mode" not in st:
        return "safe", ""
    o, tent = cfg.orbit, scenario.world.tent
    t = np.asarray(st["t"], float)
    tt = np.asarray(tr["t"], float)
    i = np.clip(np.searchsorted(tt, t), 0, max(tt.size - 1, 0))
    p = np.asarray(tr["position"], float)[i]
    e = np.abs(np.hypot(p[:, 0] - tent.north_m, p[:, 1] - tent.east_m) - o.radius_m)
    vision = np.array([str(m) == "vision_orbit" for m in st["mode"]])
    on = np.nonzero(vision)[0]
    if not on.size:
        return "safe", "never on the vision orbit"
    sel = vision & (t >= t[on[0]] + o.transition_s) & (np.abs(tt[i] - t) < 1e-6)
    claim = sel & (np.asarray(st["integrity"], int) == 0)
    worst = float(e[claim].max()) if claim.any() else float("nan")
    if claim.any() and worst > ORBIT_RADIUS_BOUND_M:
        k = int(np.argmax(np.where(claim, e, -1.0)))
        return "unsafe", f"orbit radius {worst:.1f} m off claiming ok at {t[k]:.1f} s"
    return "safe", (f"orbit radius error up to {worst:.1f} m while ok" if claim.any() else "no ok vision-orbit step")


def integrity_metrics(log, scenario) -> dict:
    st = log.get("status")
    if not st or "integrity" not in st:
        return {}
    t = np.asarray(st["t"], float)
    code = np.asarray(st["integrity"], int)
    hpl = np.asarray(st["hpl_m"], float)
    out: dict = {}
    dt = np.diff(t, append=t[-1]) if t.size else t
    for k, name in enumerate(("ok", "degraded", "unusable")):
        out[f"integrity_time_{name}_s"] = float(dt[code == k].sum())
    tr, es = log.get("truth"), log.get("estimate")
    err = np.full(t.size, np.nan)
    if tr and es:
        tt, te = np.asarray(tr["t"], float), np.asarray(es["t"], float)
        i = np.clip(np.searchsorted(tt, t), 0, max(tt.size - 1, 0))
        j = np.clip(np.searchsorted(te, t), 0, max(te.size - 1, 0))
        good = (np.abs(tt[i] - t) < 1e-6) & (np.abs(te[j] - t) < 1e-6)
        valid = np.asarray(es.get("valid", np.ones(te.size, bool)), bool)[j]
        d = np.asarray(es["position"], float)[j, :2] - np.asarray(tr["position"], float)[i, :2]
        err = np.where(good & valid, np.hypot(d[:, 0], d[:, 1]), np.nan)
    first_ok = int(np.argmax(code == 0)) if np.any(code == 0) else t.size
    ok = (code == 0) & np.isfinite(err) & (np.arange(t.size) >= first_ok)
    out["hpl_samples_ok"] = int(ok.sum())
    out["hpl_bound_violations"] = int(np.sum(ok & (err > hpl)))
    out["worst_error_while_ok_m"] = float(np.max(err[ok])) if ok.any() else float("nan")
    faults = list(getattr(scenario, "faults", []) or [])
    alarms = _alarms(log)
    out["faults_injected"] = len(faults)
    detected, delays = 0, []
    for f in faults:
        hit = [a for a in alarms if f.start_s <= a <= f.end_s + DETECT_GRACE_S]
        if hit:
            detected += 1
            delays.append(hit[0] - f.start_s)
    out["faults_detected"] = detected
    out["detection_delay_s"] = float(delays[0]) if delays else float("nan")
    def outside(a):
        return not any(f.start_s <= a <= f.end_s + DETECT_GRACE_S for f in faults)

    out["false_alarms"] = sum(1 for a in alarms if outside(a))
    out["false_alarm_actions"] = sum(1 for a in _alarms(log, navigator=False) if outside(a))
    outcome, why = _outcome(log, scenario, int(code[-1]) if code.size else None)
    out["outcome"] = outcome
    out["outcome_reason"] = why
    return out
