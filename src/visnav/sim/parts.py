"""What a mission builder returns (``app/missions.py`` ``@register``): the parts ``app/loop.Simulation`` drives,
a core every flying system states in full (``MissionParts``) with its rates (``Timing``), what it does at fixed
points of a step (``Hooks``) and where measurements go (``Routing``); or a run in which nothing flies
(``GroundTest``). A leaf module, so that the builders in ``app/*_parts.py`` import it without importing the
registry."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from visnav.sensors.base import TruthHistory
from visnav.navigation.integrity import STATE_CODES


@dataclass
class Timing:
    """The loop's rates besides the controller's own ``rate_hz`` (every one a whole number of dynamics steps,
    ``sim/clock.rate_divisor``)."""

    mission_hz: float  # the mission manager (the R-MAX's 10 Hz, the deck's and the autopilots' 50 Hz)
    sensor_grid: bool  # True: every sensor on the dynamics grid; False: each at its own instants j / rate_hz
    log_hz: float | None = None  # the logger; None: with the mission
    end_inclusive: bool = False  # the last step at t = duration too (the deck landing's loop)


@dataclass
class Hooks:
    """What a system does at fixed points of a step besides the core blocks (None: nothing there)."""

    environment: Callable | None = None  # environment(k, t) -> vehicles/base.Environment; None: still air
    actuator: Callable | None = None  # actuator(t, command) -> the command the vehicle gets (a sweep added)
    contact: Callable | None = None  # contact(t): after the log, before the vehicle steps; True ends the run
    world_step: Callable | None = None  # world_step(dt): what moves besides the vehicle (a gimbal)
    after_step: Callable | None = None  # after_step(t, t_prev): after the vehicle stepped to t; True ends the run
    start: Callable | None = None  # start(t): before the first step, after the nav_init (an operator's first click)
    finish: Callable | None = None  # finish(t, completed): after the loop, before the metrics


@dataclass
class Routing:
    """Where measurements go besides the navigator, and what the mission and controller fly on."""

    gates: dict = field(default_factory=dict)  # sensor name -> wanted(t): it samples only while wanted (a camera)
    observers: dict = field(default_factory=dict)  # measurement type -> who takes it instead of the navigator
    on_delivered: Callable | None = None  # on_delivered(t, m): after the navigator took m (an operator)
    uplink: object = None  # a sensors/link.Link the navigator's ground-station outputs (pop_uplink()) cross
    flight_navigator: object = None  # what the mission and controller fly on, if not the navigator (an autopilot's)


@dataclass
class MissionParts:
    """Everything the loop drives (``app/loop.Simulation``); the loop builds nothing. Every system states all of
    its core parts (its vehicle, truth, logger, streams and rates: none is another system's by default).

    ``sensors``: name -> sensor (``rate_hz``, ``latency_s``, ``sample(t, truth_at, world)`` -> a measurement, a
    tuple of them or None, optional ``phase_s``), sampled in this order. ``truth``: what the sensors read as
    ``truth_at`` (``advance(t)`` each step, ``latest``; ``VehicleTruth``, ``CurrentTruth``), advanced to t = 0
    by the builder. ``logger(step)``: the run's streams at ``timing.log_hz``, documented in ``streams`` (the
    log's own schema, ``sim/streams.py``). ``nav_init``: an explicit start of the navigator (a surveyed pose),
    sent before the first step and logged in ``nav_init``. ``camera_model`` / ``mount``: the navigator's camera
    (recordings write them to camera.yaml). ``extra_metrics``: more ``metrics(log, scenario) -> dict`` merged
    into the run's (integrity). ``notes``: how the scenario was set up (the command line prints them).
    ``extras``: what is particular to the system, typed by it, for tests (``DeckExtras``, ``GeolocExtras`` in
    ``app/*_parts.py``).
    """

    world: object  # world/scene.World: ground (rendered by the cameras) and wind; DeckWorld; CondorWorld; ...
    sensors: dict
    navigator: object  # navigation/base.Navigator
    mission: object  # .step(t, estimate, health) -> (reference, mode); .mode; .done; .on_touchdown(t)
    controller: object  # .rate_hz; .command(t, estimate, reference) -> command
    vehicle: object  # .state; .step(command, dt, environment)
    truth: object
    logger: Callable  # logger(step: Step)
    metrics: Callable  # metrics(log, scenario, *, wall_time_s, error) -> dict (from the log only)
    streams: dict  # stream -> field -> (units, frame, description)
    timing: Timing
    hooks: Hooks = field(default_factory=Hooks)
    routing: Routing = field(default_factory=Routing)
    nav_init: object = None  # measurements.NavInit | None
    camera_model: object = None
    mount: object = None
    extra_metrics: tuple = ()
    notes: list = field(default_factory=list)
    extras: object = None


@dataclass
class GroundTest:
    """A run in which nothing flies (the CONDOR ground test), in the loop's run scaffold: ``evaluate(progress)``
    records its streams (documented in ``streams``), the metrics come from the log."""

    mission: object  # .finish(t) once evaluated; .mode
    metrics: Callable
    evaluate: Callable
    streams: dict
    extra_metrics: tuple = ()
    notes: list = field(default_factory=list)
    extras: object = None


@dataclass
class Step:
    """What the loop has at one step, for a logger: time, truth now, the latest estimate / health /
    reference / command / mode."""

    t: float
    truth: object
    estimate: object
    health: object
    reference: object
    command: object
    mode: str


class VehicleTruth(TruthHistory):
    """``truth_at`` of a vehicle's recent states on the dynamics grid (``advance(t)`` pushes its state now)."""

    def __init__(self, vehicle, dt: float, horizon_s: float) -> None:
        super().__init__(dt, horizon_s)
        self.vehicle = vehicle

    def state(self, t: float):
        """The vehicle's true state at step ``t`` (as a ``VehicleState``)."""
        return self.vehicle.state

    def advance(self, t: float) -> None:
        self.push(self.state(t))


class CurrentTruth:
    """``truth_at`` for sensors that describe the current step (no unknown delay): the vehicle's state now,
    built only at the steps where something samples it."""

    def __init__(self, vehicle) -> None:
        self.vehicle, self.now = vehicle, 0.0

    def advance(self, t: float) -> None:
        self.now = t

    @property
    def latest(self):
        return self.vehicle.state

    def __call__(self, t: float):
        if abs(t - self.now) > 1e-9:
            raise ValueError(f"truth is asked for t={t:.4f}s at step t={self.now:.4f}s: a sensor that "
                             f"describes another instant needs sensors/base.TruthHistory")
        return self.vehicle.state


class IntegrityStatus:
    """The navigator's integrity as the R-MAX loop logs it (``status``: mode, source, integrity code, HPL,
    k^2, in the R-MAX's fields) for a system whose navigator does not log its own transitions (the deck,
    CONDOR): each change of state seen here is also an ``integrity_event`` (state, reason, HPL), so that
    ``analysis/integrity_metrics.py`` scores these runs as it scores the R-MAX's (an alarm is a departure
    from ``ok`` once the navigator has been ok: the first logged state is an event, so a navigator ok from
    the start has been ok). A change is stamped at the first logged step that shows it (the deck logs every
    step, CONDOR at 10 Hz)."""

    def __init__(self, record) -> None:
        self.record, self.codes, self.code = record, STATE_CODES, None  # the first state is an event too

    def __call__(self, t: float, health, mode) -> None:
        if health is None:
            return
        code = self.codes.get(health.integrity, -1)
        self.record("status", t, mode=mode or "", source=health.source, integrity=code, hpl_m=float(health.hpl_m),
                    k2=float(health.consistency_k2))
        if code != self.code:
            self.code = code
            self.record("integrity_event", t, state=code, reason=health.integrity_reason, hpl=float(health.hpl_m))
