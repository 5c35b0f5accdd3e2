"""The one closed-loop simulation of every system: sensors -> latency queue -> navigator -> mission ->
controller -> vehicle.

The loop owns the clock: one fixed dynamics step (``run.dt_s``, 100 Hz); every other block at its own rate
as an integer divisor of it (``sim/clock.rate_divisor``). Each measurement is stamped with the instant it
describes and delivered after its sensor's latency (a heap). Everything else is a part from the mission's
builder (``app/missions.py`` -> ``sim/parts.MissionParts``): world, vehicle, truth, sensors, navigator
(and the flight navigator it flies on, where that is another), mission, controller, environment (wind,
ground effect), logger, contact, uplink (a latency + drop channel), metrics; the R-MAX's where a builder
leaves them out (``app/rmax_parts.py``). The R-MAX: IMU 100 Hz, mission + position loop 10 Hz, GPS and
laser 10 Hz, sonar 20 Hz, camera 30 Hz capture with every 3rd frame processed (only those are rendered).
Truth reaches only the sensors (through ``truth_at``), the log, the system's contact / logging parts and an
explicit, logged ``NavInit``. ``run_scaffold``: the one run scaffold (wall time, errors, Ctrl-C, metrics
from the log).
"""

from __future__ import annotations

import heapq
import itertools
import sys
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from visnav.scenarios.schema import Scenario
from visnav.sensors.camera import PendingFrame
from visnav.sim.clock import rate_divisor as _divisor
from visnav.sensors.faults import inject_faults
from visnav.flightlog import FlightLog
from visnav.app.missions import BuildContext
from visnav.app.missions import build as build_mission
from visnav.sim.parts import Step, VehicleTruth
from visnav.app.rmax_parts import fill_rmax_defaults
from visnav.sim.streams import RMAX_STREAMS
from visnav.vehicles.base import Environment
from visnav.analysis.outcome import apply_outcome
from visnav.io.tum import trajectory_rmse, tum_frame


#: the interpreter's switch interval while frames render on the worker thread [s] (``Simulation._fly``): the
#: worker takes the GIL back after each of a frame's ~5 OpenCV calls while the loop runs Python on the other
#: core; a palace frame replayed beside a busy thread waited ~0.65 ms for it at 0.1 ms, ~0.3 ms at 10-30 us
#: (BENCHMARKS.md, speed round 5)
RENDER_SWITCH_INTERVAL_S = 2e-5


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
        ctx = BuildContext(sc, self.log.record, navigator_wrapper)
        self.parts = parts = build_mission(ctx) if builder is None else builder(ctx)
        self.log.set_schema(RMAX_STREAMS if parts.streams is None else parts.streams)
        self.world = parts.world
        # [[faults]] (issue #18): the faulted sensors wrapped, gusts added to the world's wind
        self.sensors = inject_faults(parts.sensors, self.world, sc.faults, ctx.rng[7])
        self.camera = self.sensors.get("camera")
        self.camera_model, self.mount = parts.camera_model, parts.mount
        self.mission = parts.mission
        self.nav = parts.navigator  # (wrapped by navigator_wrapper where given: the mission holds the same)
        self.notes = list(parts.info.get("notes", []))  # how the scenario was set up (the CLI prints them)
        self.info = parts.info
        if parts.evaluate is None:
            fill_rmax_defaults(parts, self)  # the R-MAX's parts where the builder left them out
        self.vehicle, self.controller, self._metrics = parts.vehicle, parts.controller, parts.metrics
        self.logger = parts.logger
        if parts.evaluate is not None:  # nothing flies (the CONDOR ground test)
            self.history = None
        elif parts.truth is None:
            self.history = VehicleTruth(self.vehicle, self.dt, horizon_s=parts.truth_horizon_s)
            self.history.advance(0.0)
        else:
            self.history = parts.truth  # (advanced to t = 0 by its builder)
        self.step_state = None

        self._queue: list = []
        self._render_pool: ThreadPoolExecutor | None = None
        self._seq = itertools.count()
        #: what was due while a frame still rendered: (t due at, measurement), delivered in this order later
        self._backlog: deque = deque()
        #: deliveries may wait (in order) for a frame still rendering until something reads the navigator
        #: (``settle``); off for a wrapped navigator: ``visnav record`` logs the step each measurement is
        #: delivered at, ``--sil`` forwards it to another process in wall-clock time
        self.defer_deliveries = navigator_wrapper is None
        #: frames render on a worker thread (the second core) while the loop steps on; off, they render on the
        #: loop's thread when taken (the same numbers): a campaign that runs a simulation per core does not
        #: gain a core from the thread, and the thread's hand-overs cost CPU (``app/montecarlo``)
        self.render_thread = True

    @property
    def flight_nav(self):
        """What the mission and the controller fly on: the navigator (``sim.nav``, which ``app/sil.py`` may swap
        for its proxy before the run), or the system's flight navigator where it has one (an autopilot's)."""
        fn = self.parts.flight_navigator
        return self.nav if fn is None else fn

    @property
    def truth(self):
        """What the sensors read as ``truth_at``."""
        return self.history

    # ------------------------------------------------------------------------------------
    def _emit(self, m, latency: float) -> None:
        if m is None:
            return
        if isinstance(m, tuple):  # a sensor that delivers several measurements (IMU + attitude)
            for x in m:
                self._emit(x, latency)
            return
        heapq.heappush(self._queue, (m.t + latency, next(self._seq), m))

    def _sensor_schedule(self) -> tuple[list, list]:
        """([period, next time, sample function] of the sensors sampled at their own instants (truth
        interpolated between dynamics steps, so the rate need not divide the step), [divisor, sample
        function] of those sampled on the dynamics grid. A gated sensor (a camera) samples only while
        its gate wants it; a sensor that renders (``sample_async``) does so on a second thread while the
        loop steps through its latency."""
        h, w = self.history, self.world
        own, grid = [], []
        for name, s in self.sensors.items():
            gate = self.parts.gates.get(name)
            rendered = self._render_pool is not None and hasattr(s, "sample_async") and s.latency_s >= self.dt
            prework = getattr(self.nav, "frame_prework", None) if rendered else None
            if prework is not None:  # the navigator's work on the image, on the render thread ahead of delivery
                sample = lambda t, s=s, pre=prework: s.sample_async(t, h, w, self._render_pool, then=pre())  # noqa: E731
            elif rendered:
                sample = lambda t, s=s: s.sample_async(t, h, w, self._render_pool)  # noqa: E731
            else:
                sample = lambda t, s=s: s.sample(t, h, w)  # noqa: E731
            # a gate reads the mission, a navigator's prework its state now, a pan-tilt camera the head the
            # navigator points: what was due before is delivered first. A camera that reads nothing but the
            # truth and the world (``samples_truth_only``), under no gate or one that reads only the mission's
            # mode (``mission/base.mode_gate``), is sampled without it: its frame renders while the loop
            # delivers the one before (the navigator gets the same measurements in the same order)
            independent = (prework is None and getattr(s, "samples_truth_only", False)
                           and (gate is None or not getattr(gate, "reads_deliveries", True)))
            if (gate is not None or rendered) and not independent:
                def fn(t, s=s, gate=gate, sample=sample):
                    if self._backlog:
                        self.settle()
                    if gate is None or gate(t):
                        self._emit(sample(t), s.latency_s)
            elif gate is not None:
                def fn(t, s=s, gate=gate, sample=sample):
                    if gate(t):
                        self._emit(sample(t), s.latency_s)
            else:
                fn = lambda t, s=s, sample=sample: self._emit(sample(t), s.latency_s)  # noqa: E731
            phase = getattr(s, "phase_s", 0.0)  # the first sample's instant
            if self.parts.sensor_grid:
                grid.append([_divisor(s.rate_hz, self.dt), int(round(phase / self.dt)), fn])
            else:
                own.append([1.0 / s.rate_hz, phase, fn])
        return own, grid

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
        operator after a delivery, no uplink, the navigator is the one flown on) and the loop renders."""
        p = self.parts
        return (self.defer_deliveries and self._render_pool is not None and not p.observers
                and p.on_delivered is None and p.uplink is None and p.flight_navigator is None)

    def _deliver_deferred(self, t: float) -> None:
        """``_deliver`` for the navigator alone, without waiting on the render thread: a frame still
        rendering when it is due, and everything due after it, wait in ``_backlog`` (in delivery order) and
        go to the navigator once the frame is done or when something reads the navigator (``settle``).
        The navigator gets the same measurements in the same order, and every reader sees it as the
        undeferred loop would; only the wall-clock instant of ``update`` moves, later, while the loop
        steps on the other core."""
        q, backlog, nav = self._queue, self._backlog, self.nav
        while q and q[0][0] <= t + 1e-9:
            m = heapq.heappop(q)[2]
            if backlog or (isinstance(m, PendingFrame) and not m.done()):
                backlog.append((t, m))
            else:
                nav.update(m.result() if isinstance(m, PendingFrame) else m)
        if backlog:
            self._drain(wait=False)

    def _drain(self, wait: bool) -> None:
        """Deliver the backlog in order; a frame still rendering stops it unless ``wait``."""
        backlog, nav, now = self._backlog, self.nav, self._t
        while backlog:
            t, m = backlog[0]
            if isinstance(m, PendingFrame):
                if not (wait or m.done()):
                    break
                self._t = t  # (an error names the step the measurement was due at, as without the wait)
                m = m.result()
            backlog.popleft()
            self._t = t
            nav.update(m)
        self._t = now

    def settle(self) -> None:
        """Everything due so far delivered (waiting for the frames still rendering): the loop calls it before
        anything reads the navigator or the mission; a part that reads the navigator outside the loop's
        stages calls it first (``rmax_parts.Touchdown``)."""
        if self._backlog:
            self._drain(wait=True)

    def _deliver(self, t: float) -> None:
        """Everything due by ``t``: to an observer of its type (a mission's motion-capture view) or to the
        navigator; what the navigator's ground-station half sends crosses the uplink and comes back later."""
        q, nav, observers, after, link = self._queue, self.flight_nav, self.parts.observers, self.parts.on_delivered, self.parts.uplink
        while q and q[0][0] <= t + 1e-9:
            m = heapq.heappop(q)[2]
            if isinstance(m, PendingFrame):
                m = m.result()
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
                        heapq.heappush(q, (t_del, next(self._seq), fix))

    def run(self, progress=None) -> RunResult:
        """Fly the scenario (``run_scaffold``: wall time, an exception or Ctrl-C stops the run and it keeps
        what it has, metrics from the log)."""
        return run_scaffold(self, self.parts.evaluate or self._fly, progress)

    def _fly(self, progress) -> None:
        sc, dt, p = self.sc, self.dt, self.parts
        n = int(round(sc.run.duration_s / dt)) + (1 if p.end_inclusive else 0)
        d_mis = _divisor(p.mission_hz, dt)  # mission manager
        d_ctrl = _divisor(self.controller.rate_hz, dt)  # the controller's own rate
        d_log = d_mis if p.log_hz is None else _divisor(p.log_hz, dt)
        # frames render on a second thread while the loop steps through the camera latency
        if self.render_thread and any(hasattr(s, "sample_async") and s.latency_s >= dt for s in self.sensors.values()):
            self._render_pool = ThreadPoolExecutor(1)
            # the worker takes the GIL back after each OpenCV call; while the loop runs Python it would wait
            # for the interpreter's switch interval (5 ms) each time, so a frame of ~3 ms CPU would take tens
            # of ms: hand the GIL over within 20 us during the run (restored at the end)
            self._switch_interval = sys.getswitchinterval()
            sys.setswitchinterval(min(self._switch_interval, RENDER_SWITCH_INTERVAL_S))
        own, grid = self._sensor_schedule()
        defer = self._can_defer()
        settle = self.settle
        # the parts that run every step settle first unless they say they settle themselves where they read
        # the navigator (the R-MAX's touchdown)
        every_step = [x for x in (p.contact, p.world_step, p.actuator, p.after_step)
                      if x is not None and not getattr(x, "settles_itself", False)]
        truth, nav, mission, controller, vehicle, logger = (self.history, self.flight_nav, self.mission,
                                                            self.controller, self.vehicle, self.logger)
        environment, actuator, contact, after_step, world_step = (p.environment, p.actuator, p.contact, p.after_step,
                                                                  p.world_step)
        still = Environment()  # no environment part: still air, no ground effect
        self._initialize_navigator()
        if p.start is not None:
            p.start(0.0)
        cmd = p.initial_command
        ref = mode = health = nav_est = None
        self.step_state = st = Step(0.0, None, None, None, None, cmd, "")
        completed = False
        try:
            for k in range(n):
                t = self._t = k * dt
                if k:
                    truth.advance(t)
                # sensors (each at its own instants up to now, or on the grid) -> latency queues
                for item in own:
                    while item[1] <= t + 1e-9:
                        item[2](item[1])
                        item[1] += item[0]
                for d, off, fn in grid:
                    if k % d == off:
                        fn(t)
                # deliveries -> navigator
                if defer:
                    if self._backlog or (self._queue and self._queue[0][0] <= t + 1e-9):
                        self._deliver_deferred(t)
                elif self._queue and self._queue[0][0] <= t + 1e-9:
                    self._deliver(t)
                    if mission.done:  # (a ground station's mission that finished on a delivery)
                        break
                # mission manager and controller (their own rates)
                mission_due, ctrl_due, log_due = k % d_mis == 0, k % d_ctrl == 0, k % d_log == 0
                if self._backlog and (mission_due or ctrl_due or log_due or every_step):
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
                self._finish(completed)

    def _finish(self, completed: bool) -> None:
        if self._render_pool is not None:
            self._render_pool.shutdown(wait=True, cancel_futures=True)
            self._render_pool = None
            sys.setswitchinterval(self._switch_interval)
        if self.parts.finish is not None:
            self.parts.finish(self._t, completed)


def run_scaffold(sim, fly, progress=None) -> RunResult:
    """The one run scaffold of every simulation: the wall time, an exception (one ``error`` line in the log)
    or Ctrl-C (``interrupted``) stops the run and it keeps what it has, the metrics come from the log."""
    sc, log = sim.sc, sim.log
    sim._t = 0.0
    error, interrupted = None, False
    wall0 = time.perf_counter()
    try:
        fly(progress)
    except Exception as exc:  # keep what we have: the run directory is still written
        t = sim._t
        error = f"{type(exc).__name__} at t={t:.2f}s: {exc}"
        log.record("error", t, message=error)
    except KeyboardInterrupt:  # Ctrl-C: stop here and keep what the run has
        interrupted = True
    wall = time.perf_counter() - wall0
    metrics = sim._metrics(log, sc, wall_time_s=wall, error=error)  # from the log only
    for extra in sim.parts.extra_metrics:
        metrics.update(extra(log, sc))
    return RunResult(scenario=sc, log=log, metrics=metrics, error=error, interrupted=interrupted)
