"""The one closed-loop simulation of every system: sensors -> latency queue -> navigator -> mission ->
controller -> vehicle.

The loop owns the clock: one fixed dynamics step (``run.dt_s``, 100 Hz); every other block at its own rate
as an integer divisor of it (``sim/clock.rate_divisor``). Each step: truth advanced, sensors sampled, what is
due delivered, mission and controller on the navigator's estimate, the log, contact, the vehicle stepped.
When each sensor samples and when its measurements are delivered (the latency heap, frames rendered on a
worker thread, deliveries deferred behind a frame still rendering) is ``app/schedule.SensorSchedule``.
Everything else is a part from the mission's builder (``app/missions.py`` -> ``sim/parts.MissionParts``):
world, vehicle, truth, sensors, navigator, mission, controller, logger, metrics, timing; hooks (environment:
wind, ground effect; contact; after-step; ...); routing (gates, observers, uplink, the flight navigator it
flies on where that is another); the R-MAX's from ``app/rmax_parts.rmax_parts``. The R-MAX: IMU 100 Hz,
mission + position loop 10 Hz, GPS and laser 10 Hz, sonar 20 Hz, camera 30 Hz capture with every 3rd frame
processed (only those are rendered). Truth reaches only the sensors (through ``truth_at``), the log, the
system's contact / logging parts and an explicit, logged ``NavInit``. ``run_scaffold``: the one run scaffold
(wall time, errors, Ctrl-C, metrics from the log).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from visnav.scenarios.schema import Scenario
from visnav.sim.clock import rate_divisor as _divisor
from visnav.sensors.faults import inject_faults
from visnav.flightlog import FlightLog
from visnav.app.missions import BuildContext
from visnav.app.missions import build as build_mission
from visnav.sim.parts import GroundTest, Step
from visnav.app.schedule import SensorSchedule
from visnav.vehicles.base import Environment
from visnav.analysis.outcome import apply_outcome
from visnav.io.tum import trajectory_rmse, tum_frame


@dataclass
class RunResult:
    scenario: Scenario
    log: FlightLog
    metrics: dict = field(default_factory=dict)
    error: str | None = None
    interrupted: bool = False  # Ctrl-C stopped the loop; the log and metrics are what it had

    def __post_init__(self) -> None:
        if "ate_rmse_m" not in self.metrics and tum_frame(self.scenario) is not None:
            ate = trajectory_rmse(self.log)  # = evo_ape on the run's truth.tum / estimate.tum
            if ate is not None:
                self.metrics["ate_rmse_m"] = ate

        apply_outcome(self.metrics, self.log, self.scenario, self.interrupted)  # issue #30: one word for the run


class Simulation:
    def __init__(self, scenario: Scenario, navigator_wrapper=None, builder=None):
        """``navigator_wrapper(nav) -> nav``, when given, wraps the navigator the loop and the mission
        talk to (``visnav record`` puts a recording proxy there). ``builder(ctx) -> MissionParts``, when
        given, builds the parts instead of the one registered for the scenario's ``mission.type`` (a system
        being written, a test)."""
        self.sc = sc = scenario
        self.dt = sc.run.dt_s
        self.log = FlightLog()
        self._t = 0.0
        #: the sensors' sampling, the latency queue and the frames rendered on a worker thread
        self.schedule = SensorSchedule(self.dt)
        #: what the loop has at the step (the logger's argument; a part that logs a step of its own reads it)
        self.step_state = Step(0.0, None, None, None, None, None, "")
        #: deliveries may wait (in order) for a frame still rendering until something reads the navigator
        #: (``settle``); off for a wrapped navigator: ``visnav record`` logs the step each measurement is
        #: delivered at, ``--sil`` forwards it to another process in wall-clock time
        self.defer_deliveries = navigator_wrapper is None
        #: frames render on a worker thread (the second core) while the loop steps on; off, they render on the
        #: loop's thread when taken (the same numbers): a campaign that runs a simulation per core does not
        #: gain a core from the thread, and the thread's hand-overs cost CPU (``app/montecarlo``)
        self.render_thread = True
        ctx = BuildContext(sc, self.log.record, navigator_wrapper, step=self.step_state, settle=self.settle)
        self.parts = parts = build_mission(ctx) if builder is None else builder(ctx)
        self.log.set_schema(parts.streams)
        self.mission, self._metrics = parts.mission, parts.metrics
        self.notes, self.extras = list(parts.notes), parts.extras  # (the CLI prints the notes)
        if isinstance(parts, GroundTest):  # nothing flies
            self.world = self.nav = self.vehicle = self.controller = self.logger = self.history = None
            self.sensors, self.camera, self.camera_model, self.mount = {}, None, None, None
            return
        self.world = parts.world
        # [[faults]] (issue #18): the faulted sensors wrapped, gusts added to the world's wind
        self.sensors = inject_faults(parts.sensors, self.world, sc.faults, ctx.rng[7])
        self.camera = self.sensors.get("camera")
        self.camera_model, self.mount = parts.camera_model, parts.mount
        self.nav = parts.navigator  # (wrapped by navigator_wrapper where given: the mission holds the same)
        self.vehicle, self.controller, self.logger = parts.vehicle, parts.controller, parts.logger
        self.history = parts.truth

    @property
    def flight_nav(self):
        """What the mission and the controller fly on: the navigator (``sim.nav``), or the system's flight
        navigator where it has one (an autopilot's)."""
        fn = self.parts.routing.flight_navigator
        return self.nav if fn is None else fn

    @property
    def truth(self):
        """What the sensors read as ``truth_at``."""
        return self.history

    @property
    def now(self) -> float:
        """The step the loop is at, or the one a measurement delivered late was due at (an error names it)."""
        due = self.schedule.due_at
        return self._t if due is None else due

    def settle(self) -> None:
        """Everything due so far delivered (``SensorSchedule.settle``): before anything reads the navigator."""
        self.schedule.settle()

    # ------------------------------------------------------------------------------------
    def _initialize_navigator(self) -> None:
        """An explicit start of the navigator (a surveyed pose): logged, then sent."""
        init = self.parts.nav_init
        if init is None:
            return
        nan3 = np.full(3, np.nan)
        v = lambda x: nan3 if x is None else np.asarray(x, float)  # noqa: E731
        self.log.record("nav_init", init.t, source=init.source, position=v(init.position), velocity=v(init.velocity),
                        attitude=v(init.attitude))
        self.nav.initialize(init)

    def _can_defer(self) -> bool:
        """Deliveries may wait for a frame only where the navigator alone takes them (no observer, no
        operator after a delivery, no uplink, the navigator is the one flown on)."""
        r = self.parts.routing
        return (self.defer_deliveries and not r.observers and r.on_delivered is None and r.uplink is None
                and r.flight_navigator is None)

    def _deliver(self, t: float) -> None:
        """Everything due by ``t``: to an observer of its type (a mission's motion-capture view) or to the
        navigator; what the navigator's ground-station half sends crosses the uplink and comes back later."""
        sched, nav, r = self.schedule, self.flight_nav, self.parts.routing
        observers, after, link = r.observers, r.on_delivered, r.uplink
        while sched.due(t):
            m = sched.pop()
            obs = observers.get(type(m)) if observers else None
            if obs is not None:
                obs(m)
                continue
            nav.update(m)
            if after is not None:
                after(t, m)
            if link is not None:
                for fix in self.nav.pop_uplink():
                    t_del = link.transmit(t, fix)
                    self.log.record("uplink", fix.t, sent_at=t, delivered=t_del is not None, radius=fix.range)
                    if t_del is not None:
                        sched.push(t_del, fix)

    def run(self, progress=None) -> RunResult:
        """Fly the scenario (``run_scaffold``: wall time, an exception or Ctrl-C stops the run and it keeps
        what it has, metrics from the log)."""
        return run_scaffold(self, self.parts.evaluate if isinstance(self.parts, GroundTest) else self._fly, progress)

    def _fly(self, progress) -> None:
        sc, dt, p = self.sc, self.dt, self.parts
        hooks, timing, sched = p.hooks, p.timing, self.schedule
        n = int(round(sc.run.duration_s / dt)) + (1 if timing.end_inclusive else 0)
        d_mis = _divisor(timing.mission_hz, dt)  # mission manager
        d_ctrl = _divisor(self.controller.rate_hz, dt)  # the controller's own rate
        d_log = d_mis if timing.log_hz is None else _divisor(timing.log_hz, dt)
        sched.open(self.sensors, p.routing.gates, self.history, self.world, self.nav, timing.sensor_grid,
                   self.render_thread, self._can_defer())
        defer, settle = sched.deferred, sched.settle
        # the parts that run every step settle first unless they say they settle themselves where they read
        # the navigator (the R-MAX's touchdown)
        every_step = [x for x in (hooks.contact, hooks.world_step, hooks.actuator, hooks.after_step)
                      if x is not None and not getattr(x, "settles_itself", False)]
        truth, nav, mission, controller, vehicle, logger = (self.history, self.flight_nav, self.mission,
                                                            self.controller, self.vehicle, self.logger)
        environment, actuator, contact, after_step, world_step = (hooks.environment, hooks.actuator, hooks.contact,
                                                                  hooks.after_step, hooks.world_step)
        still = Environment()  # no environment part: still air, no ground effect
        self._initialize_navigator()
        if hooks.start is not None:
            hooks.start(0.0)
        cmd = ref = mode = health = nav_est = None
        st = self.step_state
        completed = False
        try:
            for k in range(n):
                t = self._t = k * dt
                if k:
                    truth.advance(t)
                # sensors (each at its own instants up to now, or on the grid) -> latency queue
                sched.sample(k, t)
                # deliveries -> navigator
                if defer:
                    if sched.waiting or sched.due(t):
                        sched.deliver_deferred(t)
                elif sched.due(t):
                    self._deliver(t)
                    if mission.done:  # (a ground station's mission that finished on a delivery)
                        break
                # mission manager and controller (their own rates), on the navigator's estimate
                mission_due, ctrl_due, log_due = k % d_mis == 0, k % d_ctrl == 0, k % d_log == 0
                if sched.waiting and (mission_due or ctrl_due or log_due or every_step):
                    settle()
                if mission_due or ctrl_due:
                    nav_est = nav.estimate(t)
                if mission_due:
                    health = nav.health(t)
                    ref, mode = mission.step(t, nav_est, health)
                if ctrl_due:
                    cmd = controller.command(t, nav_est, ref)
                if log_due:
                    st.t, st.truth, st.estimate, st.health, st.reference, st.command, st.mode = (
                        t, truth.latest, nav_est, health, ref, cmd, mode)
                    logger(st)
                    if progress is not None:
                        progress(t, n * dt)
                if mission_due and mission.done:
                    break
                if contact is not None and contact(t):
                    break
                # vehicle dynamics in its environment (wind, ground effect)
                env = still if environment is None else environment(k, t)
                if world_step is not None:
                    world_step(dt)
                vehicle.step(cmd if actuator is None else actuator(t, cmd), dt, env)
                if after_step is not None and after_step(t + dt, t):
                    break
            completed = True
        finally:
            try:
                settle()  # what was due by the last step (an error it raises came first)
            finally:
                sched.close()
                if hooks.finish is not None:
                    hooks.finish(self._t, completed)


def run_scaffold(sim, fly, progress=None) -> RunResult:
    """The one run scaffold of every simulation: the wall time, an exception (one ``error`` line in the log)
    or Ctrl-C (``interrupted``) stops the run and it keeps what it has, the metrics come from the log."""
    sc, log = sim.sc, sim.log
    error, interrupted = None, False
    wall0 = time.perf_counter()
    try:
        fly(progress)
    except Exception as exc:  # keep what we have: the run directory is still written
        t = sim.now
        error = f"{type(exc).__name__} at t={t:.2f}s: {exc}"
        log.record("error", t, message=error)
    except KeyboardInterrupt:  # Ctrl-C: stop here and keep what the run has
        interrupted = True
    wall = time.perf_counter() - wall0
    metrics = sim._metrics(log, sc, wall_time_s=wall, error=error)  # from the log only
    for extra in sim.parts.extra_metrics:
        metrics.update(extra(log, sc))
    return RunResult(scenario=sc, log=log, metrics=metrics, error=error, interrupted=interrupted)
