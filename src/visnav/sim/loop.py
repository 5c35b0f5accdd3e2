"""The closed-loop simulation: sensors -> navigator -> mission -> controller -> vehicle.

One fixed dynamics step (``run.dt_s``, 100 Hz); every other block runs at its own rate as an
integer divisor of it: IMU 100 Hz, mission + position loop 10 Hz, GPS and laser 10 Hz, sonar
20 Hz, camera 30 Hz capture with every 3rd frame processed (only those are rendered). Each
measurement is stamped with the instant it describes and delivered after its sensor's latency.
Truth reaches only the sensors (through ``TruthHistory``), the log and an explicit, logged ``NavInit``.
The parts come from the mission's builder (``sim/missions.py``); the loop builds nothing else.
"""

from __future__ import annotations

import heapq
import itertools
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from visnav.measurements import VehicleState, YacsCommand
from visnav.scenarios.schema import Scenario
from visnav.sensors.base import TruthHistory
from visnav.sensors.camera import PendingFrame
from visnav.sim.clock import rate_divisor as _divisor
from visnav.analysis.integrity_metrics import integrity_metrics
from visnav.navigation.integrity import STATE_CODES
from visnav.sensors.faults import inject_faults
from visnav.sim.log import FlightLog
from visnav.sim.missions import BuildContext
from visnav.sim.missions import build as build_mission
from visnav.sim.streams import RMAX_STREAMS
from visnav.vehicles.base import Environment
from visnav.vehicles.rmax import RmaxModel


@dataclass
class RunResult:
    scenario: Scenario
    log: FlightLog
    metrics: dict = field(default_factory=dict)
    error: str | None = None
    interrupted: bool = False  # Ctrl-C stopped the loop; the log and metrics are what it had

    def __post_init__(self) -> None:
        from visnav.io.tum import trajectory_rmse, tum_frame

        if "ate_rmse_m" not in self.metrics and tum_frame(self.scenario) is not None:
            ate = trajectory_rmse(self.log)  # = evo_ape on the run's truth.tum / estimate.tum
            if ate is not None:
                self.metrics["ate_rmse_m"] = ate


class Simulation:
    def __init__(self, scenario: Scenario, navigator_wrapper=None):
        """``navigator_wrapper(nav) -> nav``, when given, wraps the navigator the loop and the mission
        talk to (``visnav record`` puts a recording proxy there)."""
        self.sc = sc = scenario
        self.dt = sc.run.dt_s
        self.log = FlightLog(schema=RMAX_STREAMS)
        ctx = BuildContext(sc, self.log.record, navigator_wrapper)
        self.parts = parts = build_mission(ctx)
        self.world = parts.world
        # [[faults]] (issue #18): the faulted sensors wrapped, gusts added to the world's wind
        self.sensors = inject_faults(parts.sensors, self.world, sc.faults, ctx.rng[7])
        self.camera = self.sensors.get("camera")
        self.camera_model, self.mount = parts.camera_model, parts.mount
        self.mission, self.controller, self._metrics = parts.mission, parts.controller, parts.metrics
        self.nav = parts.navigator  # (wrapped by navigator_wrapper where given: the mission holds the same)
        self.notes = list(parts.info.get("notes", []))  # how the scenario was set up (the CLI prints them)
        init = VehicleState(t=0.0, position=np.asarray(parts.start_position, float), velocity=np.zeros(3),
                            euler=np.array([0.0, 0.0, parts.start_yaw]), body_rates=np.zeros(3),
                            specific_force=np.array([0.0, 0.0, -9.81]))
        self.vehicle = RmaxModel(dt=self.dt, initial=init)
        self.history = TruthHistory(self.dt, horizon_s=2.5)

        self._queue: list = []
        self._render_pool: ThreadPoolExecutor | None = None
        self._seq = itertools.count()

    # ------------------------------------------------------------------------------------
    def _emit(self, m, latency: float) -> None:
        if m is None:
            return
        if isinstance(m, tuple):  # a sensor that delivers several measurements (IMU + attitude)
            for x in m:
                self._emit(x, latency)
            return
        heapq.heappush(self._queue, (m.t + latency, next(self._seq), m))

    def _sensor_schedule(self) -> list[list]:
        """[period, next time, sample function] of every sensor; each samples truth at its own
        instants (interpolated between dynamics steps), so its rate need not divide the step. The
        camera renders only while the mission wants frames."""
        h, w = self.history, self.world
        items = []
        for name, s in self.sensors.items():
            if name == "camera":
                def camera(t, s=s):
                    if self.mission.camera_wanted(t):
                        if self._render_pool is not None:
                            self._emit(s.sample_async(t, h, w, self._render_pool), s.latency_s)
                        else:
                            self._emit(s.sample(t, h, w), s.latency_s)

                items.append((s.rate_hz, camera))
            else:
                items.append((s.rate_hz, lambda t, s=s: self._emit(s.sample(t, h, w), s.latency_s)))
        return [[1.0 / r, 0.0, f] for r, f in items]

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

    def run(self, progress=None) -> RunResult:
        """Fly the scenario; on an exception the run stops and keeps what it has."""
        sc, dt, log = self.sc, self.dt, self.log
        n = int(round(sc.run.duration_s / dt))
        d_pos = _divisor(10.0, dt)  # mission manager (and the PALACE position loop)
        d_ctrl = _divisor(self.controller.rate_hz, dt)  # the controller's own rate
        d_wind = _divisor(20.0, dt)  # turbulence bandwidth is a few rad/s: 20 Hz updates suffice
        # frames render on a second thread while the loop steps through the camera latency
        self._render_pool = ThreadPoolExecutor(1) if self.camera is not None and self.camera.latency_s >= dt else None
        schedule = self._sensor_schedule()
        inject = self.parts.actuator_injection
        self._initialize_navigator()
        cmd = YacsCommand(t=0.0)
        ref = None
        wind = self.world.wind.steady.ned
        wall0 = time.perf_counter()
        touchdown = None
        error = None
        t = 0.0
        interrupted = False
        try:
            for k in range(n):
                t = k * dt
                truth = self.vehicle.state
                self.history.push(truth)
                # sensors (each at its own instants up to now) -> latency queues
                for item in schedule:
                    while item[1] <= t + 1e-9:
                        item[2](item[1])
                        item[1] += item[0]
                # deliveries -> navigator
                q = self._queue
                while q and q[0][0] <= t + 1e-9:
                    m = heapq.heappop(q)[2]
                    self.nav.update(m.result() if isinstance(m, PendingFrame) else m)
                # mission manager (10 Hz) and controller (its own rate)
                mission_due, ctrl_due = k % d_pos == 0, k % d_ctrl == 0
                if mission_due or ctrl_due:
                    nav_est = self.nav.estimate(t)
                if mission_due:
                    health = self.nav.health(t)
                    ref, mode = self.mission.step(t, nav_est, health)
                if ctrl_due:
                    # no position solution yet (first GPS fix not in): hold the trim
                    cmd = self.controller.command(t, nav_est, ref) if nav_est.valid else YacsCommand(t=t)
                if mission_due:
                    self._log_step(t, truth, nav_est, ref, cmd, mode, health)
                    if self.mission.done:
                        break
                    if progress is not None:
                        progress(t, n * dt)
                # vehicle dynamics in the wind
                if k % d_wind == 0:
                    airspeed = float(np.linalg.norm(truth.velocity - self.world.wind.steady.ned))
                    wind = self.world.wind.velocity_ned(t, d_wind * dt, max(truth.height_agl, 0.5), airspeed)
                applied = cmd
                if inject is not None:
                    d = inject(t)
                    if d is not None:  # a sweep at the actuator (the loop broken where seed 000 broke it)
                        applied = YacsCommand(t=t, ail=cmd.ail + d[0], ele=cmd.ele + d[1], rud=cmd.rud + d[2],
                                              thr=cmd.thr + d[3])
                        log.record("actuator", t, controller=np.array([cmd.ail, cmd.ele, cmd.rud, cmd.thr]),
                                   injection=np.asarray(d, float),
                                   applied=np.array([applied.ail, applied.ele, applied.rud, applied.thr]))
                self.vehicle.step(applied, dt, Environment(wind))
                if self.vehicle.state.on_ground and touchdown is None and t > 1.0:
                    touchdown = self.vehicle.state
                    self.mission.on_touchdown(t + dt)
                    log.record("touchdown", t + dt, position=touchdown.position,
                               speed=float(getattr(self.vehicle, "touchdown_speed", np.nan)))
                    self._log_step(t + dt, touchdown, self.nav.estimate(t + dt), ref, cmd, "landed",
                                   self.nav.health(t + dt))
                    break
        except Exception as exc:  # keep what we have: the run directory is still written
            error = f"{type(exc).__name__} at t={t:.2f}s: {exc}"
            log.record("error", t, message=error)
        except KeyboardInterrupt:  # Ctrl-C: stop here and keep what the run has
            interrupted = True
        finally:
            if self._render_pool is not None:
                self._render_pool.shutdown(wait=True, cancel_futures=True)
                self._render_pool = None
        wall = time.perf_counter() - wall0
        metrics = self._metrics(self.log, self.sc, wall_time_s=wall, error=error)  # from the log only
        metrics.update(integrity_metrics(log, sc))  # from the log (issue #18)
        return RunResult(scenario=sc, log=log, metrics=metrics, error=error, interrupted=interrupted)

    def _log_step(self, t, truth, est, ref, cmd, mode, health) -> None:
        log = self.log
        log.record("truth", t, position=truth.position, velocity=truth.velocity, euler=truth.euler,
                   body_rates=truth.body_rates)
        log.record("estimate", t, position=est.position, velocity=est.velocity, euler=est.attitude,
                   source=est.source, valid=est.valid)
        log.record("reference", t, position=ref.position, velocity=ref.velocity, yaw=ref.yaw)
        log.record("command", t, ail=cmd.ail, ele=cmd.ele, rud=cmd.rud, thr=cmd.thr)
        log.record("status", t, mode=mode, source=health.source, coherence=health.coherence,
                   mpe_rate_hz=health.mpe_rate_hz, laser_ok=health.laser_ok, tracking=health.tracking,
                   rejected_samples=health.rejected_samples, rejected_ranges=health.rejected_ranges,
                   integrity=STATE_CODES.get(health.integrity, -1), hpl_m=health.hpl_m, k2=health.consistency_k2)
