"""The outcome of a run, in one word, and the verdict line a run's summary and report open with (issue #30 item 4).

``outcome`` is one of

* ``unsafe``: what ``analysis/integrity_metrics`` calls unsafe (a landing off its point or too fast, a crash,
  a homing far from home claiming ``ok``, a CONDOR orbit off its radius claiming ``ok``, an exception);
* ``aborted``: the mission gave up its task safely (it entered ``abort`` or ended in a go-around) and did
  not touch down;
* ``interrupted``: the user stopped the run (Ctrl-C): what it flew says nothing about the outcome;
* ``not_applicable``: the run flies nothing the navigator steers (the CONDOR ground test; the MAV
  geo-location flight, whose autopilot flies on GPS and whose estimate is the target's), so no safety
  outcome is defined;
* ``safe`` otherwise.

The verdict line names the steps where the true horizontal error exceeded the protection level while the
navigator claimed ``ok`` (``hpl_bound_violations``): a run can be ``safe`` and still have claimed more than
it had (issue #30: CONDOR orbit, 6 steps, worst 18.7 m, while the summary said ``safe``).
"""

from __future__ import annotations

import math

OUTCOMES = ("safe", "unsafe", "aborted", "interrupted", "not_applicable")

#: modes in which a mission has given up its task (PALACE / pad / WITAS ``abort``, the deck's ``go-around``)
ABORT_MODES = ("abort", "aborted", "go-around")


def _not_applicable(scenario) -> str | None:
    m = scenario.mission
    kind = getattr(m, "type", "")
    if kind == "condor" and getattr(m, "experiment", "orbit") != "orbit":
        return "the CONDOR ground test flies nothing"
    if kind == "mav-geolocation":
        return "the autopilot flies on GPS; the estimate is the target's position, it steers nothing"
    return None


def run_outcome(log, scenario, metrics: dict, interrupted: bool = False) -> tuple[str, str]:
    """(outcome, why) of a run from its log, its scenario and its metrics (``outcome`` / ``outcome_reason`` of
    ``integrity_metrics`` where the navigator logs its integrity)."""
    if interrupted:
        t = metrics.get("sim_time_s")
        return "interrupted", "stopped by the user (Ctrl-C)" + (f" at t={t:.1f} s" if isinstance(t, float)
                                                                   and math.isfinite(t) else "")
    why = _not_applicable(scenario)
    if why is not None:
        return "not_applicable", why
    base, reason = metrics.get("outcome"), str(metrics.get("outcome_reason", "") or "")
    if base is None:  # no integrity logged: the same crash criteria
        if log.get("error"):
            return "unsafe", "the run stopped on an exception"
        base, reason = "safe", ""
    if base == "safe" and not reason:
        reason = "no crash, no exception" + (", no touchdown" if not log.get("touchdown") else "")
    if base == "unsafe":
        return "unsafe", reason
    md = log.get("mode")
    modes = [str(x) for x in md["mode"]] if md else []
    if modes and not log.get("touchdown") and (modes[-1] in ABORT_MODES or "abort" in modes):
        last = next(m for m in reversed(modes) if m in ABORT_MODES)
        i = len(modes) - 1 - modes[::-1].index(last)
        r = str(md["reason"][i]) if "reason" in md and md["reason"][i] else ""
        return "aborted", f"{last} at t={float(md['t'][i]):.1f} s" + (f": {r}" if r else "")
    if base == "safe":  # an abort is its own outcome now: what is left of "held or aborted" is held
        reason = reason.replace(" (held or aborted)", " (held)").replace(" (held or went around)", " (held)")
    return base, reason


def apply_outcome(metrics: dict, log, scenario, interrupted: bool = False) -> dict:
    """Set ``outcome`` / ``outcome_reason`` of ``metrics`` (in place, also returned); the same on a metrics dict
    that already has them (a run's, rescored)."""
    metrics["outcome"], metrics["outcome_reason"] = run_outcome(log, scenario, metrics, interrupted)
    return metrics


def verdict_line(metrics: dict) -> str:
    """The first line of a run's summary: the outcome, why, and the HPL violations while ``ok`` if any."""
    out = metrics.get("outcome", "not_applicable")
    why = metrics.get("outcome_reason") or ""
    line = f"outcome: {out}" + (f" ({why})" if why else "")
    n = metrics.get("hpl_bound_violations")
    if isinstance(n, (int, float)) and n > 0:
        worst = metrics.get("worst_error_while_ok_m")
        of = metrics.get("hpl_samples_ok")
        line += (f"; {int(n)} step{'s' if n != 1 else ''}" + (f" of {int(of)}" if of else "")
                 + " with the true error over the HPL while the navigator claimed ok"
                 + (f" (worst error while ok {worst:.1f} m)" if isinstance(worst, float) and math.isfinite(worst) else ""))
    return line


def replay_verdict(metrics: dict, navigator: str) -> str:
    """The first line of a replay's summary and report (a replay flies nothing, so it has no outcome): how much
    of the recording the navigator estimated, and its accuracy against the recording's reference, the
    GPS-denied part's first where ``--gps-until`` withheld the GPS; or why it stopped."""
    dur = metrics.get("flight_duration_s", float("nan"))
    head = f"replay on {navigator}: {dur:.1f} s"
    if metrics.get("error"):
        return f"{head}, stopped early: {metrics['error']} (what it had is kept)"
    if metrics.get("interrupted"):
        return f"{head}, interrupted (Ctrl-C): the run directory holds the replay up to there"
    share = metrics.get("estimate_valid_share")
    line = head + (f", a valid estimate at {100 * share:.0f} % of the output steps" if isinstance(share, float) else "")
    ref = metrics.get("reference")
    if not ref:
        return line + "; the recording has no reference to score it against"
    if "final_error_m" in metrics:
        line += (f"; GPS-denied {metrics['denied_s']:.0f} s over {metrics['distance_denied_m']:.0f} m: final error "
                 f"{metrics['final_error_m']:.2f} m ({metrics['final_error_pct_of_distance']:.2f} % of the distance), "
                 f"RMS {metrics['ate_rmse_denied_m']:.2f} m against {ref}")
    elif "ate_rmse_m" in metrics:
        line += f"; against {ref}: ATE RMSE {metrics['ate_rmse_m']:.3f} m, max {metrics['ate_max_m']:.3f} m"
    else:
        line += f"; not scored against {ref}: {metrics.get('ate_note', 'no overlap with the estimate')}"
    return line


def outcome_text(counts: dict[str, int]) -> str:
    """'outcomes: 18 safe, 2 aborted; 3 runs over the HPL while ok' ('' when no run has an outcome)."""
    hpl = counts.get("hpl_violated_while_ok", 0)
    words = ", ".join(f"{v} {k}" for k, v in counts.items() if k != "hpl_violated_while_ok")
    if not words:
        return ""
    return f"outcomes: {words}" + (f"; {hpl} run{'s' if hpl != 1 else ''} with steps over the HPL while ok" if hpl else "")
