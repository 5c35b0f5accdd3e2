"""The R-MAX's parts of the one loop (``app/loop.py``), which its builders (``app/missions.py``, ``witas_parts``,
``pad_parts``) leave to their defaults: the helicopter model started at the builder's pose, its wind, the
trim held while no position solution is in, the actuator sweep, the touchdown and the streams it logs."""

from __future__ import annotations

import numpy as np

from visnav.analysis.integrity_metrics import integrity_metrics
from visnav.measurements import VehicleState, YacsCommand
from visnav.navigation.integrity import STATE_CODES
from visnav.sim.clock import rate_divisor
from visnav.vehicles.base import Environment
from visnav.vehicles.rmax import RmaxModel


def rmax_vehicle(parts, dt: float) -> RmaxModel:
    """The R-MAX at the builder's start pose, at rest."""
    init = VehicleState(t=0.0, position=np.asarray(parts.start_position, float), velocity=np.zeros(3),
                        euler=np.array([0.0, 0.0, parts.start_yaw]), body_rates=np.zeros(3),
                        specific_force=np.array([0.0, 0.0, -9.81]))
    return RmaxModel(dt=dt, initial=init)


class WindEnvironment:
    """The world's wind at the vehicle, updated at 20 Hz (turbulence bandwidth is a few rad/s), for the
    turbulence at the vehicle's height and airspeed now: ``height()``, ``airspeed()``."""

    def __init__(self, wind, dt: float, height, airspeed, initial=None) -> None:
        self.wind, self.dt = wind, dt  # wind(): the world's wind (a fault may wrap it after the build)
        self.height, self.airspeed = height, airspeed
        self.d = rate_divisor(20.0, dt)
        self.now = self.wind().steady.ned if initial is None else initial
        self._env: Environment | None = None  # Environment(now), built once per new wind

    def __call__(self, k: int, t: float) -> Environment:
        if k % self.d == 0:
            self.now = self.wind().velocity_ned(t, self.d * self.dt, self.height(), self.airspeed())
        env = self._env
        if env is None or env.wind_ned is not self.now:
            env = self._env = Environment(self.now)
        return env


class HoldTrim:
    """The controller, or the trim while no position solution is in (the first GPS fix)."""

    def __init__(self, controller) -> None:
        self.inner, self.rate_hz = controller, controller.rate_hz

    def command(self, t, estimate, reference):
        return self.inner.command(t, estimate, reference) if estimate.valid else YacsCommand(t=t)

    def __getattr__(self, name):
        return getattr(self.inner, name)


class RmaxLogger:
    """The R-MAX streams (``sim/streams.RMAX_STREAMS``): truth, estimate, reference, command, status."""

    def __init__(self, record) -> None:
        self.record = record

    def __call__(self, s) -> None:
        record, truth, est, ref, cmd, health = self.record, s.truth, s.estimate, s.reference, s.command, s.health
        record("truth", s.t, position=truth.position, velocity=truth.velocity, euler=truth.euler,
               body_rates=truth.body_rates)
        record("estimate", s.t, position=est.position, velocity=est.velocity, euler=est.attitude,
               source=est.source, valid=est.valid)
        record("reference", s.t, position=ref.position, velocity=ref.velocity, yaw=ref.yaw)
        record("command", s.t, ail=cmd.ail, ele=cmd.ele, rud=cmd.rud, thr=cmd.thr)
        record("status", s.t, mode=s.mode, source=health.source, coherence=health.coherence,
               mpe_rate_hz=health.mpe_rate_hz, laser_ok=health.laser_ok, tracking=health.tracking,
               rejected_samples=health.rejected_samples, rejected_ranges=health.rejected_ranges,
               integrity=STATE_CODES.get(health.integrity, -1), hpl_m=health.hpl_m, k2=health.consistency_k2)


class Injection:
    """A sweep at the actuator (the loop broken where seed 000 broke it): ``injection(t)`` added to the
    controller's YACS command, logged in ``actuator``."""

    def __init__(self, injection, record) -> None:
        self.injection, self.record = injection, record

    def __call__(self, t: float, cmd):
        d = self.injection(t)
        if d is None:
            return cmd
        applied = YacsCommand(t=t, ail=cmd.ail + d[0], ele=cmd.ele + d[1], rud=cmd.rud + d[2], thr=cmd.thr + d[3])
        self.record("actuator", t, controller=np.array([cmd.ail, cmd.ele, cmd.rud, cmd.thr]),
                    injection=np.asarray(d, float), applied=np.array([applied.ail, applied.ele, applied.rud, applied.thr]))
        return applied


class Touchdown:
    """The skids on the ground (after the first second): the mission is told, the touchdown and the step
    logged, the run ends. It runs every step and reads the navigator only at the touchdown, so it settles
    the loop's deliveries itself there (``settles_itself``: the loop need not settle before every step)."""

    settles_itself = True

    def __init__(self, sim) -> None:
        self.sim = sim

    def __call__(self, t: float, t_prev: float) -> bool:
        sim = self.sim
        s = sim.vehicle.state
        if not (s.on_ground and t_prev > 1.0):
            return False
        sim.settle()
        sim.mission.on_touchdown(t)
        sim.log.record("touchdown", t, position=s.position, speed=float(getattr(sim.vehicle, "touchdown_speed", np.nan)))
        st = sim.step_state
        sim.logger(type(st)(t, s, sim.nav.estimate(t), sim.nav.health(t), st.reference, st.command, "landed"))
        return True


def fill_rmax_defaults(parts, sim) -> None:
    """The R-MAX's parts where the builder left them out."""
    dt = sim.dt
    if parts.vehicle is None:
        parts.vehicle = rmax_vehicle(parts, dt)
        parts.controller = HoldTrim(parts.controller)
        if parts.initial_command is None:
            parts.initial_command = YacsCommand(t=0.0)
        if parts.environment is None:
            parts.environment = WindEnvironment(
                lambda: sim.world.wind, dt, lambda: max(sim.truth.latest.height_agl, 0.5),
                lambda: float(np.linalg.norm(sim.truth.latest.velocity - sim.world.wind.steady.ned)))
        if parts.actuator_injection is not None:
            parts.actuator = Injection(parts.actuator_injection, sim.log.record)
        parts.extra_metrics = (*parts.extra_metrics, integrity_metrics)  # from the log (issue #18)
        if parts.after_step is None:
            parts.after_step = Touchdown(sim)
        if "camera" in parts.sensors and "camera" not in parts.gates and hasattr(parts.mission, "camera_wanted"):
            parts.gates["camera"] = parts.mission.camera_wanted
    if parts.logger is None:
        parts.logger = RmaxLogger(sim.log.record)
