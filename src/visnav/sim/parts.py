"""What a mission builder returns (``app/missions.py`` ``@register``): the parts ``app/loop.Simulation`` drives.
A leaf module, so that the builders in ``app/*_parts.py`` import it without importing the registry."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from visnav.sensors.base import TruthHistory


@dataclass
class MissionParts:
    """Everything the loop drives; the loop builds nothing else.

    ``sensors``: name -> sensor (``rate_hz``, ``latency_s``, ``sample(t, truth_at, world)`` -> a
    measurement, a tuple of them or None), sampled in this order, each at its own instants
    (``sensor_grid=False``: ``j / rate_hz``, interpolated between dynamics steps) or on the dynamics grid
    (``sensor_grid=True``: every ``rate_divisor(rate_hz, dt)`` steps), from its ``phase_s`` on; ``gates``: name -> ``wanted(t)``
    (a camera renders only while its mission wants frames). ``nav_init``: an explicit start of the
    navigator (a surveyed pose), sent before the first step and logged in the ``nav_init`` stream.
    ``actuator_injection(t)``: YACS increments added to the controller's output (a sweep), or None.

    The other vehicles' parts: ``vehicle`` (``state``, ``step(command, dt, environment)``; None: the R-MAX
    started at ``start_position`` / ``start_yaw``), ``truth`` (what the sensors read as ``truth_at``:
    ``advance(t)`` each step, ``latest``; None: a ``TruthHistory`` of ``truth_horizon_s`` fed with
    ``vehicle.state``), ``environment(k, t)`` (the ``vehicles/base.Environment`` of step ``k``),
    ``logger(step)`` (the run's streams at ``log_hz``; None: the R-MAX streams), ``contact(t)`` (after the
    log, before the vehicle steps: True ends the run), ``after_step(t)`` (after the vehicle stepped to
    ``t``: True ends the run), ``world_step(dt)`` (what moves besides the vehicle: a gimbal),
    ``flight_navigator`` (what the mission and the controller fly on and the sensors' messages go to when it
    is not the navigator: the autopilot's own), ``observers`` (measurement type -> who takes it instead:
    a mission's motion-capture view, the payload navigator's frames), ``uplink`` (a ``sensors/link.Link`` the navigator's ground-station outputs cross, from its
    ``pop_uplink()``), ``on_delivered(t, m)`` (what happens after the navigator took ``m``: an operator),
    ``start(t)`` (before the first step, after the ``nav_init``: an operator's first click), ``finish(t)``
    (after the loop, before the metrics), ``streams`` (the log's own schema); ``evaluate(progress)``: a run in
    which nothing flies (the CONDOR ground test), in the same run scaffold.
    """

    world: object  # world/scene.World: ground (rendered by the cameras) and wind; DeckWorld; CondorWorld
    sensors: dict
    navigator: object  # navigation/base.Navigator
    mission: object  # .step(t, estimate, health) -> (reference, mode); .mode; .done; .on_touchdown(t)
    controller: object  # .rate_hz; .command(t, estimate, reference) -> command
    metrics: Callable  # metrics(log, scenario, *, wall_time_s, error) -> dict (from the log only)
    start_position: np.ndarray | None = None
    start_yaw: float = 0.0
    camera_model: object = None  # geometry of the navigator's camera (recordings write it to camera.yaml)
    mount: object = None
    nav_init: object = None  # measurements.NavInit | None
    actuator_injection: Callable | None = None
    actuator: Callable | None = None  # actuator(t, command) -> the command the vehicle gets (a sweep added)
    info: dict = field(default_factory=dict)  # what reports and tests read (reference map, path, pad layout, notes)
    # --- the parts of the other vehicles (defaults: the R-MAX) ---
    vehicle: object = None
    flight_navigator: object = None  # what the mission and controller fly on, if not the navigator (an autopilot's)
    truth: object = None
    truth_horizon_s: float = 2.5
    sensor_grid: bool = False
    end_inclusive: bool = False  # the last step at t = duration too (the deck landing's loop)
    gates: dict = field(default_factory=dict)
    mission_hz: float = 10.0
    log_hz: float | None = None  # None: with the mission
    initial_command: object = None  # the command before the controller's first (None: the R-MAX trim)
    environment: Callable | None = None
    logger: Callable | None = None
    contact: Callable | None = None
    after_step: Callable | None = None
    world_step: Callable | None = None
    observers: dict = field(default_factory=dict)
    uplink: object = None
    on_delivered: Callable | None = None
    start: Callable | None = None  # start(t): the mission's first words (before the first step)
    finish: Callable | None = None
    evaluate: Callable | None = None  # evaluate(progress): a run where nothing flies (the CONDOR ground test)
    streams: dict | None = None
    extra_metrics: tuple = ()  # more metrics(log, scenario) -> dict merged into the run's (integrity)


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
        from visnav.navigation.integrity import STATE_CODES

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
