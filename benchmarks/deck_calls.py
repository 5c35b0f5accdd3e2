"""Per-call main-thread CPU of the deck landing's hot functions, measured inside a whole closed-loop run.

    PYTHONPATH=src python benchmarks/deck_calls.py [SCENARIO] [--seed N] [--rounds R]

Wraps each function below (where the checkout has it) with a thread-CPU timer, runs the scenario ``R``
times and prints, per function, the calls per run and the least mean CPU per call over the rounds [µs]
(inclusive: a function's callees count in it; the timer itself adds ~0.5 µs a call). Run it with two
checkouts' ``src`` on ``PYTHONPATH`` in turn to compare them (the same calls, the same inputs: the runs
are bit-identical). One JSON line at the end.
"""

from __future__ import annotations

import argparse
import importlib
import json
import time

TARGETS = [
    ("visnav.sensors.led_camera", "LedCamera.render"),
    ("visnav.vision.blobs", "find_blobs"),
    ("visnav.vision.blobs", "BearingTracker.from_pixels"),
    ("visnav.geometry.camera", "PinholeCamera.undistort_normalized"),
    ("visnav.navigation.deck", "DeckNavigator._frame"),
    ("visnav.navigation.deck", "DeckNavigator._correct"),
    ("visnav.navigation.deck", "DeckNavigator.expected_bearings"),
    ("visnav.navigation.deck", "DeckNavigator._imu"),
    ("visnav.navigation.deck", "DeckNavigator._predict"),
    ("visnav.navigation.deck", "DeckNavigator.health"),
    ("visnav.navigation.deck", "DeckNavigator.estimate"),
    ("visnav.estimation.ukf", "UnscentedKalmanFilter.predict"),
    ("visnav.estimation.ukf", "UnscentedKalmanFilter.update"),
    ("visnav.estimation.deck", "process_noise"),
    ("visnav.estimation.deck", "process_model"),
    ("visnav.estimation.association", "associate"),
    ("visnav.app.deck_parts", "DeckContact.log"),
    ("visnav.mission.deck", "DeckMission.step"),
    ("visnav.control.deck", "DeckController.command"),
    ("visnav.sensors.led_camera", "LedCamera.sample"),
    ("visnav.sensors.imu", "AccelGyro.sample"),
    ("visnav.sensors.imu", "RollPitchAhrs.sample"),
    ("visnav.sensors.deck_observer", "RelativeStateSensor.sample"),
    ("visnav.sim.parts", "VehicleTruth.advance"),
    ("visnav.vehicles.multirotor", "Multirotor.step"),
    ("visnav.app.deck_parts", "DeckContact.environment"),
    ("visnav.app.deck_parts", "DeckContact.contact"),
    ("visnav.world.deck", "DeckMotion.state"),
    ("visnav.world.deck", "relative_state"),
    ("visnav.estimation.integrity", "IntegrityMonitor.assess"),
    ("visnav.app.loop", "Simulation._deliver"),
]


def _wrap(fn, acc):
    tt = time.thread_time

    def w(*a, **k):
        t0 = tt()
        try:
            return fn(*a, **k)
        finally:
            acc[0] += tt() - t0
            acc[1] += 1

    w.__wrapped__ = fn
    return w


def install():
    accs = {}
    for mod_name, qual in TARGETS:
        mod = importlib.import_module(mod_name)
        owner, name = mod, qual
        if "." in qual:
            cls_name, name = qual.split(".")
            owner = getattr(mod, cls_name, None)
        fn = getattr(owner, name, None) if owner is not None else None
        if fn is None:
            continue
        acc = accs[qual] = [0.0, 0]
        w = _wrap(fn, acc)
        setattr(owner, name, w)
        if owner is mod:  # module functions imported by name elsewhere
            import sys

            for m in list(sys.modules.values()):
                if m is not None and m.__name__.startswith("visnav") and getattr(m, name, None) is fn:
                    setattr(m, name, w)
    return accs


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("scenario", nargs="?", default="deck-moving")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation

    import visnav.navigation.deck  # noqa: F401  (import every target's module before wrapping)
    import visnav.sensors.deck_observer  # noqa: F401
    import visnav.app.deck_parts  # noqa: F401

    accs = install()
    best: dict[str, tuple[float, int]] = {}
    runs = []
    for _ in range(a.rounds):
        for acc in accs.values():
            acc[0], acc[1] = 0.0, 0
        sim = make_simulation(load_scenario(a.scenario, seed=a.seed))
        m0 = time.thread_time()
        sim.run()
        runs.append(time.thread_time() - m0)
        for k, (s, n) in accs.items():
            us = 1e6 * s / n if n else 0.0
            if k not in best or us < best[k][0]:
                best[k] = (us, n)
    print(f"run main-thread CPU s (with timers): min {min(runs):.3f}")
    for k, (us, n) in best.items():
        print(f"{k:40s} {n:6d} calls {us:9.1f} us/call {us * n / 1e6:7.3f} s/run")
    print(json.dumps({"runs_s": runs, "per_call_us": {k: v[0] for k, v in best.items()},
                      "calls": {k: v[1] for k, v in best.items()}}))


if __name__ == "__main__":
    main()
